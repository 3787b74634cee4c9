"""A user's model file (``--model``, ``make_solver(model=)``): read without running code from
it, refused in one line naming the file (or its config.json and key) when it is not one the
learned methods can act with, and unpickled only with ``--trust-model`` / ``trust_model=True``.
"""

from __future__ import annotations

import base64
import json
import pickle
import shutil
import zipfile
from pathlib import Path

import pytest

from modquad_gym.cli import main
from modquad_gym.policy.models import DEFAULT_MODEL
from modquad_gym.solvers import make_solver
from modquad_gym.tasks import load_task, make_generator

pytest.importorskip("sb3_contrib")

TASK = "example:planted_seed1"
PLANTED = load_task(TASK)


class Payload:
    """A pickle that, when loaded, creates the file it names (code from the model file)."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)

    def __reduce__(self):
        return (open, (self.path, "w"))


def payload(path: Path) -> str:
    return base64.b64encode(pickle.dumps(Payload(path))).decode()


def rewritten(src: Path, out: Path, data=None, members=None) -> Path:
    """A copy of the model .zip ``src`` at ``out`` with its ``data`` JSON edited by ``data``
    and other members replaced by ``members`` (name -> bytes)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(out, "w") as zout:
        for item in zin.infolist():
            buf = zin.read(item.filename)
            if item.filename == "data" and data is not None:
                d = json.loads(buf)
                data(d)
                buf = json.dumps(d).encode()
            buf = (members or {}).get(item.filename, buf)
            zout.writestr(item, buf)
    return out


def solve_cli(capsys, model: Path, *extra: str, n_max: int = 7) -> tuple[int, str, str]:
    code = main(["solve", "--task", TASK, "--method", "ppo", "--n-max", str(n_max), "--model",
                 str(model), "--json", *extra])  # fmt: skip
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def mlp_models(tmp_path_factory):
    """Grid-MLP models of SB3's MultiInputPolicy at n_max 3 (``train.py --architecture mlp``),
    saved untrained: plain; with keywords JSON cannot hold (an activation class); of three
    module types with its config.json; the same without it; and an SB3 PPO for CartPole."""
    import gymnasium as gym
    from sb3_contrib import MaskablePPO
    from stable_baselines3 import PPO
    from torch import nn

    from modquad_gym.policy.policy import make_env

    root = tmp_path_factory.mktemp("mlp")
    made = {}
    for name, kwargs, env_kwargs in (
        ("plain", {"net_arch": [16]}, {}),
        ("tanh", {"net_arch": [16], "activation_fn": nn.Tanh}, {}),
        ("typed", {"net_arch": [16]}, {"modules": "t45,t45m,flat"}),
    ):
        env = make_env("planted-mixed-external" if env_kwargs else "planted", n_max=3,
                       **env_kwargs)  # fmt: skip
        path = root / name / "model.zip"
        MaskablePPO("MultiInputPolicy", env, n_steps=16, batch_size=16, seed=0,
                    policy_kwargs=kwargs, device="cpu").save(path)  # fmt: skip
        (path.parent / "config.json").write_text(
            json.dumps({"env_kwargs": {"n_max": 3, **env_kwargs}})
        )
        made[name] = path
    made["typed_nocfg"] = root / "typed_nocfg" / "model.zip"
    made["typed_nocfg"].parent.mkdir()
    shutil.copy(made["typed"], made["typed_nocfg"])
    made["cartpole"] = root / "cartpole" / "model.zip"
    PPO("MlpPolicy", gym.make("CartPole-v1"), n_steps=16, batch_size=16,
        device="cpu").save(made["cartpole"])  # fmt: skip
    return made


# --- finding 1: no code from the file runs unless the user trusts it ----------------------------


def test_an_extra_pickle_in_a_model_never_runs(tmp_path, capsys):
    """The shipped model.zip with one more ``:serialized:`` entry
    whose pickle writes a file. The model acts, by either door, and the file is never made."""
    mark = tmp_path / "pwned.txt"
    evil = rewritten(DEFAULT_MODEL, tmp_path / "evil" / "model.zip",
                     data=lambda d: d.update(evil={":type:": "x",
                                                   ":serialized:": payload(mark)}))  # fmt: skip
    code, out, err = solve_cli(capsys, evil)
    assert code == 0, err
    assert json.loads(out)["n_modules"] == 4
    assert make_solver("ppo", model=evil).solve(PLANTED).n_modules == 4
    assert make_solver("ppo-guided", model=evil, trust_model=True).solve(PLANTED).n_modules == 4
    assert not mark.exists()


def test_a_model_that_only_unpickling_reads_needs_trust(tmp_path, capsys):
    """A policy class that is a pickle of more than a class reference: refused without trust
    in one line that says why (no code runs); with ``trust_model=True`` it is unpickled (and
    then refused: what it built is no masked policy)."""
    mark = tmp_path / "pwned.txt"
    evil = rewritten(
        DEFAULT_MODEL,
        tmp_path / "evil" / "model.zip",
        data=lambda d: d["policy_class"].update({":serialized:": payload(mark)}),
    )
    with pytest.raises(ValueError) as exc:
        make_solver("ppo", model=evil)
    text = str(exc.value)
    assert text.startswith(f"model {evil}: its policy_class") and "--" not in text
    assert "run code when loaded" in text and "give trust_model=True" in text
    code, _, err = solve_cli(capsys, evil)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert f"--model {evil}" in err and "give --trust-model" in err
    assert not mark.exists()
    with pytest.raises(ValueError, match="not a MaskablePPO model"):
        make_solver("ppo", model=evil, trust_model=True)
    assert mark.exists()  # the opt-in does unpickle: documented, only for trusted files


def test_trust_model_loads_a_model_of_keywords_json_cannot_hold(mlp_models, capsys):
    """An activation class in the policy's keywords is pickled: the same words refuse it by
    both doors, and ``trust_model=True`` / ``--trust-model`` act with it alike."""
    model = mlp_models["tanh"]
    with pytest.raises(ValueError, match=r"policy_kwargs .* trust_model=True"):
        make_solver("ppo", n_max=3, model=model)
    code, _, err = solve_cli(capsys, model, n_max=3)
    assert code == 2 and "--trust-model" in err and "policy_kwargs" in err
    python = make_solver("ppo", n_max=3, model=model, trust_model=True).solve(PLANTED)
    code, out, err = solve_cli(capsys, model, "--trust-model", n_max=3)
    assert code == 0, err
    assert json.loads(out)["cells"] == ([list(c) for c in python.structure.cells]
                                        if python.structure else None)  # fmt: skip


def test_models_of_the_known_policies_need_no_flag(mlp_models, tmp_path, capsys):
    """What ``python train.py`` writes (either architecture) and the shipped models act
    without ``--trust-model``: a grid-MLP model, and the default model's zip without its
    NumPy actor (read by torch with weights only)."""
    assert make_solver("ppo", n_max=3, model=mlp_models["plain"]).solve(PLANTED) is not None
    bare = tmp_path / "bare" / "model.zip"
    bare.parent.mkdir()
    shutil.copy(DEFAULT_MODEL, bare)
    shutil.copy(DEFAULT_MODEL.with_name("config.json"), bare.with_name("config.json"))
    solver = make_solver("ppo", model=bare)
    assert solver.policy.actor is None  # the torch network: no export beside it
    expected = make_solver("ppo").solve(PLANTED)
    assert solver.solve(PLANTED).structure.cells == expected.structure.cells
    code, _, err = solve_cli(capsys, bare)
    assert code == 0, err


def test_trust_model_is_refused_where_nothing_uses_it(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = main(["solve", "--task", TASK, "--method", "greedy", "--trust-model"])
    assert code == 2 and "--trust-model" in capsys.readouterr().err
    code = main(["score", "--methods", "greedy", "--trust-model", "--limit", "1"])
    assert code == 2 and "--trust-model: not used" in capsys.readouterr().err


def test_continuing_training_unpickles_only_a_trusted_or_shipped_model(tmp_path, capsys,
                                                                       monkeypatch):  # fmt: skip
    """``train.py --resume`` and expert iteration's ``--model`` load the whole file
    (MaskablePPO.load): a copy of the shipped model outside the package needs
    ``--trust-model``; the shipped model needs none; ``--trust-model`` alone is refused."""
    from agents.cli import parse_args
    from agents.expert_iteration import parse_args as exit_args

    monkeypatch.chdir(tmp_path)
    copy = tmp_path / "mine" / "model.zip"
    copy.parent.mkdir()
    shutil.copy(DEFAULT_MODEL, copy)
    with pytest.raises(SystemExit):
        parse_args(["--out", "run", "--resume", str(copy)])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"--resume {copy}: continuing training unpickles it" in err and "--trust-model" in err
    args = parse_args(["--out", "run", "--resume", str(copy), "--trust-model"])
    assert args.config.resume == copy
    assert parse_args(["--out", "run2", "--resume", str(DEFAULT_MODEL)]).config.resume
    with pytest.raises(SystemExit):
        parse_args(["--out", "run3", "--trust-model"])
    assert "--trust-model: only with --resume" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        exit_args(["--model", str(copy), "--out", "exit"])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"--model {copy}: training it further unpickles it" in err
    assert exit_args(["--model", str(copy), "--out", "exit", "--trust-model"]).trust_model


# --- finding 3: a bad model file is one line naming it, exit 2 ----------------------------------


def garbage_class(d):
    d["policy_class"][":serialized:"] = base64.b64encode(b"\x80\x04garbage").decode()


def truncated_class(d):
    text = d["policy_class"][":serialized:"]
    d["policy_class"][":serialized:"] = text[: len(text) // 2 // 4 * 4]


@pytest.mark.parametrize(
    "name, edit, members",
    [
        ("garbage_class", garbage_class, None),
        ("truncated_class", truncated_class, None),
        ("garbage_weights", None, {"policy.pth": b"\x00garbage" * 10}),
    ],
)
def test_a_corrupt_model_is_one_line_naming_it(tmp_path, capsys, name, edit, members):
    bad = rewritten(DEFAULT_MODEL, tmp_path / name / "model.zip", edit, members)
    for trust in ((), ("--trust-model",)):
        code, _, err = solve_cli(capsys, bad, *trust)
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert f"--model {bad}: not a MaskablePPO model .zip" in err
    with pytest.raises(ValueError, match=f"model {bad}: not a MaskablePPO model"):
        make_solver("ppo", model=bad)


def test_a_model_of_another_environment_is_one_line_naming_it(mlp_models, tmp_path, capsys):
    """An SB3 PPO for CartPole (a Box observation): solve and score say what it is, exit 2."""
    model = mlp_models["cartpole"]
    code, _, err = solve_cli(capsys, model)
    assert code == 2 and f"--model {model}: not a model of the assembly environment" in err
    code = main(["score", "--methods", "ppo", "--model", str(model), "--limit", "1",
                 "--out", str(tmp_path / "score")])  # fmt: skip
    assert code == 2 and "not a model of the assembly environment" in capsys.readouterr().err
    with pytest.raises(ValueError, match=f"^model {model}: not a model of the assembly"):
        make_solver("ppo", model=model)


# --- finding 4: config.json checked against the saved spaces, named with its key ---------------


def configured(tmp_path: Path, env_kwargs: dict, source: Path = DEFAULT_MODEL) -> Path:
    """A copy of the model ``source`` (its NumPy actor too, when it has one) with a
    config.json of these ``env_kwargs``."""
    folder = tmp_path / "model"
    folder.mkdir(parents=True)
    for name in ("model.zip", "model_actor.npz"):
        if source.with_name(name).is_file():
            shutil.copy(source.with_name(name), folder / name)
    (folder / "config.json").write_text(json.dumps({"env_kwargs": env_kwargs}))
    return folder / "model.zip"


@pytest.mark.parametrize(
    "env_kwargs, key",
    [
        ({"n_max": "seven"}, "n_max"),
        ({"n_max": -3}, "n_max"),
        ({"n_max": True}, "n_max"),
        ({"n_max": 3}, "n_max"),  # the saved grid holds 7
        ({"lookahead": "bogus"}, "lookahead"),
        ({"lookahead": True}, "lookahead"),  # the saved rows are the exact lookahead's
        ({"oracle_method": "bogus"}, "oracle_method"),
        ({"n_directions": "x"}, "n_directions"),
        ({"lookahead_top_k": 0}, "lookahead_top_k"),
        ({"modules": "nope"}, "modules"),
        ({"modules": "t45,flat"}, "modules"),  # the saved spaces hold one type
        ({"bogus_key": 1}, "bogus_key"),
        ({"lookahed": "exact"}, "lookahed"),
    ],
)
def test_a_bad_config_json_names_the_file_and_the_key(tmp_path, capsys, env_kwargs, key):
    model = configured(tmp_path, {"tasks": "mixed", **env_kwargs})
    where = f"{model.with_name('config.json')}: env_kwargs.{key}"
    with pytest.raises(ValueError, match="^" + str(where).replace(".", r"\.")):
        make_solver("ppo", model=model)
    code, _, err = solve_cli(capsys, model)
    assert code == 2 and where in err and len(err.strip().splitlines()) == 1


def test_the_saved_grid_wins_over_config_json(mlp_models, tmp_path, capsys):
    """A grid-MLP model of n_max 3 beside a config saying 7 or 2, or the exact lookahead:
    refused naming config.json and the key, never SB3's shape error or a false budget."""
    for env_kwargs, key in (({"n_max": 7}, "n_max"), ({"n_max": 2}, "n_max"),
                            ({"lookahead": "exact"}, "lookahead")):  # fmt: skip
        model = configured(tmp_path / key / str(env_kwargs[key]), env_kwargs,
                           mlp_models["plain"])  # fmt: skip
        with pytest.raises(ValueError, match=f"config.json: env_kwargs.{key} is "):
            make_solver("ppo", n_max=3, model=model)


def test_a_grid_model_of_several_types_needs_its_config(mlp_models, capsys):
    """Without its config.json, a three-type grid model's types are unknown: said so, by
    either door, with or without --modules (never a claim about the types it was trained
    with)."""
    model = mlp_models["typed_nocfg"]
    for extra in ((), ("--modules", "t45,t45m,flat")):
        code, _, err = solve_cli(capsys, model, *extra, n_max=3)
        assert code == 2 and "3 module types but no env_kwargs.modules" in err
        assert "config.json" in err and "Unexpected observation shape" not in err


def test_the_report_never_says_none_for_what_config_json_lacks(tmp_path, capsys):
    """The default model beside a config.json that records no training run."""
    model, out = configured(tmp_path, {"n_max": 7}), tmp_path / "score"
    code = main(["score", "--methods", "ppo", "--model", str(model), "--limit", "1",
                 "--no-progress", "--out", str(out)])  # fmt: skip
    assert code == 0, capsys.readouterr().err
    line = next(x for x in (out / "benchmark.md").read_text().splitlines()
                if x.startswith("PPO model:"))  # fmt: skip
    assert "None" not in line and "records no training run" in line


# --- finding 8: the Python door's words ---------------------------------------------------------


def test_the_python_door_names_model_and_advice_that_works(mlp_models):
    with pytest.raises(ValueError) as exc:
        make_solver("ppo", model="")
    assert str(exc.value) == "model: an empty path; give the model .zip file"
    with pytest.raises(ValueError) as exc:  # a three-type grid model asked for one type
        make_solver("ppo", n_max=3, model=mlp_models["typed"])
    text = str(exc.value)
    assert text.startswith(f"model {mlp_models['typed']}: trained with the module types")
    assert "ppo_mixed" not in text and "--model" not in text and "size-free" in text
    generate = make_generator("planted-mixed-external", n_max=3)
    task = generate(__import__("numpy").random.default_rng(0))
    from modquad_gym.geometry.module import palette

    solver = make_solver("ppo", n_max=3, model=mlp_models["typed"],
                         modules=palette("t45,t45m,flat"))  # fmt: skip
    assert solver.solve(task) is not None
