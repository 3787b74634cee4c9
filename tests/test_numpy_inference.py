"""The shipped policy acts without torch (modquad_gym/policy/inference.py): its NumPy actor gives
the torch network's logits, choices and probabilities on real episodes; a stale export is never
used; the shipped exports match their models; ``modquad solve --method ppo`` runs with torch
missing."""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from modquad_gym.geometry.module import palette
from modquad_gym.policy.inference import (
    LAYERS,
    arrays_hash,
    export_path,
    exported,
    file_hash,
    inference_model,
)
from modquad_gym.policy.models import DEFAULT_MODEL, MODELS_DIR, SCALE_MODEL
from modquad_gym.policy.policy import Policy
from modquad_gym.tasks import make_generator

MIXED_MODEL = MODELS_DIR / "ppo_mixed" / "model.zip"
EXAMPLE = MODELS_DIR.parents[0] / "examples" / "paper_seed0.json"


def torch_logits(policy: Policy, obs: dict, valid: np.ndarray) -> np.ndarray:
    """The torch scorer's logits of the actions ``valid`` at ``obs``."""
    import torch

    obs_t, _ = policy.net.obs_to_tensor(obs)
    with torch.no_grad():
        return policy.net.features_extractor(obs_t)[0, valid].numpy()


def torch_probabilities(policy: Policy, obs: dict, mask: np.ndarray) -> np.ndarray:
    """``Policy.probabilities`` through the torch network (sb3-contrib's distribution)."""
    actor, policy.actor = policy.actor, None
    try:
        return policy.probabilities(obs, mask)
    finally:
        policy.actor = actor


@pytest.mark.parametrize(
    "model, n_max, family, top_k, modules",
    [(DEFAULT_MODEL, 7, "mixed", None, None), (SCALE_MODEL, 16, "planted", 8, None),
     (SCALE_MODEL, 64, "planted", 8, None), (SCALE_MODEL, 16, "paper", 1, None),
     (MIXED_MODEL, 7, "planted-mixed-external", None, None),
     (DEFAULT_MODEL, 7, "planted-mixed-external", 8, "t45,t45m,flat")],
)  # fmt: skip
def test_numpy_actor_equals_the_torch_network_on_episodes(model, n_max, family, top_k, modules):
    """Every state of a greedy episode (every start type of a palette; the last case: a
    one-type model rebuilt for a palette): the NumPy logits of the valid actions equal
    torch's within float32 rounding, the greedy action is the same unless the best two are
    tied, and so are the probabilities (zero on masked actions)."""
    pytest.importorskip("torch")
    pytest.importorskip("sb3_contrib")
    policy = Policy(model, n_max=n_max, top_k=top_k)
    if modules is not None:
        policy.use_palette(palette(modules))
        assert len(policy.starts) == 3
    assert policy.actor is not None
    task = make_generator(family)(np.random.default_rng(n_max))
    states = 0
    for start in policy.starts:
        obs, info = policy.reset(task, start)
        done = info["success"]
        while not done:
            mask = policy.env.action_masks()
            valid = np.flatnonzero(mask)
            assert valid.size < mask.size  # masked actions in every state
            assert top_k != 1 or valid.size == 1
            ours, theirs = policy.actor.logits(obs, valid), torch_logits(policy, obs, valid)
            scale = max(1.0, float(np.abs(theirs).max()))
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=2e-5 * scale)
            action = policy.greedy(obs, mask)
            torch_action = int(policy.net.predict(obs, action_masks=mask, deterministic=True)[0])
            top2 = np.sort(theirs)[-2:]
            assert action == torch_action or top2[1] - top2[0] < 1e-4 * scale
            probs = policy.probabilities(obs, mask)
            np.testing.assert_allclose(probs, torch_probabilities(policy, obs, mask), atol=1e-5)
            assert np.all(probs[~mask] == 0) and probs.sum() == pytest.approx(1.0)
            obs, _, terminated, truncated, info = policy.env.step(action)
            done, states = terminated or truncated, states + 1
    assert states >= 2


def test_a_stale_export_falls_back_to_torch(tmp_path):
    """An export of another model.zip (hash mismatch) or an unreadable one is never used: the
    policy acts with torch, as without an export."""
    pytest.importorskip("torch")
    pytest.importorskip("sb3_contrib")
    model = tmp_path / "model.zip"
    shutil.copyfile(DEFAULT_MODEL, model)
    shutil.copyfile(export_path(MIXED_MODEL), export_path(model))  # another model's weights
    assert exported(model) is None
    policy = Policy(model, n_max=5)
    assert policy.actor is None and policy.net is not None
    obs, _ = policy.reset(make_generator("mixed")(np.random.default_rng(0)))
    mask = policy.env.action_masks()
    assert policy.greedy(obs, mask) == int(policy.net.predict(obs, action_masks=mask,
                                                              deterministic=True)[0])  # fmt: skip
    export_path(model).write_bytes(b"not an npz")
    assert exported(model) is None
    shutil.copyfile(export_path(DEFAULT_MODEL), export_path(model))  # its own: fresh again
    assert exported(model) is not None and Policy(model, n_max=5).actor is not None


def test_an_edited_and_resaved_export_is_never_acted_on(tmp_path, monkeypatch):
    """An export whose weights were changed and saved again with the same keys, shapes and
    dtypes (and its model.zip's hash) fails its own digest: the policy acts with torch, and
    without torch the refusal is one line naming the file."""
    model = tmp_path / "model.zip"
    shutil.copyfile(DEFAULT_MODEL, model)
    with np.load(export_path(DEFAULT_MODEL)) as data:
        arrays = {k: data[k] for k in data.files}
    bias = arrays["score_out.bias"] + np.float32(0.5)  # every logit shifted: the same choices
    weight = arrays["mix.weight"].copy()
    weight[0, 0] = -weight[0, 0]
    types = arrays["types"].copy()
    types[0, -1] *= 2.0
    for change in ({}, {"score_out.bias": bias}, {"mix.weight": weight}, {"types": types}):
        with export_path(model).open("wb") as fh:  # re-saved, unchanged or edited
            np.savez(fh, **edited(arrays, **change))
        assert (exported(model) is not None) == (not change)
    if importlib.util.find_spec("torch") and importlib.util.find_spec("sb3_contrib"):
        policy = Policy(model, n_max=5)
        assert policy.actor is None and policy.net is not None
    for name in ("torch", "stable_baselines3", "sb3_contrib"):
        monkeypatch.setitem(sys.modules, name, None)
    with pytest.raises(
        ImportError, match=r"^\S*model_actor.npz: not the actor of model.zip"
    ) as err:
        inference_model(model)
    assert "\n" not in str(err.value) and "torch is not installed" in str(err.value)
    export_path(model).write_bytes(export_path(DEFAULT_MODEL).read_bytes())
    assert inference_model(model).path == model  # its own export again: no torch needed


def edited(arrays: dict, **changes) -> dict:
    """``arrays`` with ``changes`` (None removes a key)."""
    out = {k: v for k, v in arrays.items() if changes.get(k, v) is not None}
    out.update({k: np.asarray(v) for k, v in changes.items() if v is not None})
    return out


def corrupt_exports(arrays: dict) -> dict:
    """Exports of DEFAULT_MODEL's hash that must not be read: cut, missing, extra or odd keys,
    wrong dtypes and shapes, non-finite weights, sizes of no environment."""
    nan = arrays["mix.weight"].copy()
    nan[0, 0] = np.nan
    return {
        "no mix.bias": edited(arrays, **{"mix.bias": None}),
        "an extra key": edited(arrays, surprise=np.zeros(3)),
        "hidden of two": edited(arrays, hidden=[64, 64]),
        "a float width": edited(arrays, **{"width.task": 55.0}),
        "a zero width": edited(arrays, **{"width.occupancy": 0}),
        "odd candidates": edited(arrays, **{"width.candidates": 1353}),
        "complex weights": edited(arrays, **{"mix.weight": arrays["mix.weight"] + 1j}),
        "integer weights": edited(arrays, **{"mix.weight": arrays["mix.weight"].astype(int)}),
        "two outputs": edited(
            arrays,
            **{
                "score_out.weight": np.zeros((2, 64), np.float32),
                "score_out.bias": np.zeros(2, np.float32),
            },
        ),
        "a bias of one": edited(arrays, **{"mix.bias": np.zeros(1, np.float32)}),
        "a 3-d weight": edited(arrays, **{"mix.weight": arrays["mix.weight"][None]}),
        "a NaN weight": edited(arrays, **{"mix.weight": nan}),
        "an inf bias": edited(arrays, **{"score_out.bias": np.array([np.inf], np.float32)}),
        "NaN types": edited(arrays, types=arrays["types"] * np.nan),
        "two types": edited(arrays, types=np.zeros((2, 7))),
    }


def test_a_corrupt_export_is_never_read(tmp_path):
    """An export cut short, empty, a folder, a dangling link, or with keys, dtypes, shapes or
    values no :func:`export` writes (NaN weights would give NaN probabilities; a second output
    column would be dropped silently) is not read: the policy acts with torch. A broken
    config.json beside the model is refused in one line naming it."""
    model = tmp_path / "model.zip"
    shutil.copyfile(DEFAULT_MODEL, model)
    target = export_path(model)
    good = export_path(DEFAULT_MODEL).read_bytes()
    with np.load(export_path(DEFAULT_MODEL)) as data:
        arrays = {k: data[k] for k in data.files}
    for name, changed in corrupt_exports(arrays).items():
        changed["actor_sha256"] = np.str_(arrays_hash(changed))  # past the digest: the checks
        with target.open("wb") as fh:
            np.savez(fh, **changed)
        assert exported(model) is None, name
    for raw in (b"", good[: len(good) // 2]):
        target.write_bytes(raw)
        assert exported(model) is None
    target.unlink()
    target.symlink_to(tmp_path / "missing.npz")
    assert exported(model) is None
    target.unlink()
    target.mkdir()
    assert exported(model) is None
    target.rmdir()
    target.write_bytes(good)
    assert exported(model) is not None
    for text in ("{not json", "[1]", '{"env_kwargs": 3}'):
        (tmp_path / "config.json").write_text(text)
        with pytest.raises(ValueError, match=r"^\S*config.json: not a model's config") as err:
            exported(model)
        assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "model", sorted(MODELS_DIR.glob("*/model.zip")), ids=lambda p: p.parent.name
)
def test_every_shipped_model_has_a_fresh_export(model):
    """Each shipped export is its model.zip's (hash), unedited (its own digest) and holds the
    zip's actor weights exactly. A shipped model retrained without re-export fails here (re-export:
    ``python -c "from modquad_gym.policy.inference import export; export('PATH')"``)."""
    data = np.load(export_path(model))
    assert str(data["model_sha256"]) == file_hash(model)
    assert str(data["actor_sha256"]) == arrays_hash(dict(data))
    assert exported(model) is not None
    if importlib.util.find_spec("torch") and importlib.util.find_spec("sb3_contrib"):
        from modquad_gym.policy.models import read_model

        weights = read_model(model).weights  # the zip's own: the export holds them exactly
        for key in (f"{name}.{p}" for name in LAYERS for p in ("weight", "bias")):
            np.testing.assert_array_equal(data[key], weights[f"pi_features_extractor.{key}"])


@pytest.mark.parametrize(
    "model", sorted(MODELS_DIR.glob("*/model.zip")), ids=lambda p: p.parent.name
)
def test_no_shipped_model_names_a_tensorboard_folder(model):
    """SB3's ``learn`` after ``MaskablePPO.load`` writes TensorBoard events to the saved
    ``tensorboard_log`` unless given a logger: a shipped model names none (a developer's folder
    would be created on the user's machine; fix: ``agents.publishing.without_log_folder``, then
    re-export)."""
    with zipfile.ZipFile(model) as archive:
        assert json.loads(archive.read("data"))["tensorboard_log"] is None


def test_solve_with_ppo_runs_without_torch():
    """``modquad solve --method ppo`` (and ppo-guided) with the shipped model where torch and SB3
    cannot be imported: the same JSON fields, a verified answer."""
    script = (
        "import sys\n"
        "for m in ('torch', 'stable_baselines3', 'sb3_contrib'): sys.modules[m] = None\n"
        "from modquad_gym.cli import main\n"
        "codes = [main(['solve', '--task', sys.argv[1], '--method', m, '--json'])\n"
        "         for m in ('ppo', 'ppo-guided')]\n"
        "assert 'torch' not in sys.modules or sys.modules['torch'] is None\n"
        "sys.exit(max(codes))\n"
    )
    run = subprocess.run([sys.executable, "-c", script, str(EXAMPLE)], capture_output=True,
                         text=True, timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert [r["method"] for r in lines] == ["ppo", "ppo-guided"]
    assert all(r["feasible"] and r["n_modules"] >= r["lower_bound"] for r in lines)
