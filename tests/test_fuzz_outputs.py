"""Property tests over hostile input, part two (issue 24): ``train.py``'s options and the outputs
of ``optima`` and the benchmarks. Same contract and settings as ``test_fuzz.py``: exit 0 or 2, no
traceback, an error line naming the option; and nothing a user saved is changed without
``--force``."""

from __future__ import annotations

import json

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from test_fuzz import FUZZ, HOSTILE, _argv, options, run_bench, run_main

from modquad_gym.scoring.optima import KEYS

INT_OPTIONS = ("--seed", "--timesteps", "--n-envs", "--n-max", "--eval-freq", "--n-eval",
               "--checkpoint-freq", "--threads", "--demo-tasks", "--bc-epochs", "--workers",
               "--seed-workers")  # fmt: skip
JSON_VALUES = ['{"bogus": 1}', "[]", "1", "{", '{"lookahead": "yes"}', '{"n_max": 3}', "{}"]
HYPERPARAMETERS = st.dictionaries(
    st.sampled_from(
        [
            "learning_rate",
            "n_steps",
            "batch_size",
            "n_epochs",
            "gamma",
            "gae_lambda",
            "clip_range",
            "ent_coef",
            "vf_coef",
            "max_grad_norm",
            "net_arch",
            "lr",
        ]
    ),  # fmt: skip
    st.sampled_from(
        [
            -1,
            0,
            1,
            2,
            0.5,
            1.5,
            1e-4,
            10**12,
            "1",
            None,
            True,
            [],
            [64],
            [0],
            [-3],
            float("inf"),
            64,
        ]
    ),  # fmt: skip
    max_size=3,
)
TRAIN_OPTIONS = {
    **{name: st.sampled_from([*HOSTILE, "1", "2", "3", "7"]) for name in INT_OPTIONS},
    "--env-kwargs": st.sampled_from(JSON_VALUES),
    "--hyperparameters": HYPERPARAMETERS.map(json.dumps) | st.sampled_from(JSON_VALUES),
    "--task-source": st.sampled_from(["nope", "planted", "paper", "", "missing.json"]),
    "--tier": st.sampled_from(["current", "large", "mixed", "dynamic", "huge"]),
    "--vec-env": st.sampled_from(["dummy", "subproc", "bogus"]),
    "--expert": st.sampled_from(["all", "first", "best"]),
    "--resume": st.sampled_from(["missing.zip", ".", "junk.zip"]),
}


@pytest.fixture()
def train_cli():
    from agents.cli import parse_args

    return parse_args


@FUZZ
@given(pairs=options(TRAIN_OPTIONS), seeds=st.sampled_from([None, ["1", "2"], ["-1", "2"],
                                                             ["3", "3"], ["x"]]))  # fmt: skip
def test_train_options(tmp_path, capsys, monkeypatch, train_cli, pairs, seeds):
    """Parsing train.py's options either accepts them or stops with one error line (exit 2)
    naming an option; an accepted recipe builds its environment and its PPO model."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "junk.zip").write_text("not a model")
    argv = ["--out", str(tmp_path / "run"), "--tensorboard", str(tmp_path / "tb"), *_argv(pairs)]
    if seeds is not None:
        argv += ["--seeds", *seeds] if not seeds[0].startswith("-") else [f"--seeds={seeds[0]}"]
    try:
        args = train_cli(argv)
    except SystemExit as exc:
        err = capsys.readouterr().err
        assert exc.code == 2 and "Traceback" not in err, err
        assert "error: " in err.strip().splitlines()[-1], err
        return
    config = args.config
    if config is not None and config.hyperparameters:
        _build_model(config)


def _build_model(config) -> None:
    """The accepted hyperparameters make a MaskablePPO (SB3 would refuse nonsense here)."""
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.training import _new_model
    from modquad_gym.policy.ppo import make_env

    kwargs = config.eval_env_kwargs  # the network's observation (candidates: lookahead rows)
    venv = DummyVecEnv([lambda: make_env(tasks="planted", n_max=3, **kwargs)])
    try:
        _new_model(config, venv, MaskablePPO)
    finally:
        venv.close()


# ------------------------------------------------------------------ outputs: nothing is lost
OTHER = {"task": "other.json", "name": "other", "digest": "0" * 16, "optimum": None}
RECORD = json.dumps({**dict.fromkeys(KEYS, 0), **OTHER, "n_max": 2, "structures": []}).encode()
"""A record of another task (a valid one: records are checked key by key when read)."""
CONTENTS = st.one_of(
    st.binary(max_size=200),
    st.sampled_from(
        [
            b"",
            RECORD + b"\n",
            RECORD + b"\n" + RECORD[:20],
            RECORD[:9],
            b'{"a": 1}',
            b'{"a": 1}\n',
            b"\n",
            RECORD,
        ]
    ),  # fmt: skip
)


@FUZZ
@given(content=CONTENTS, force=st.booleans())
def test_optima_never_loses_what_the_out_file_held(tmp_path, capsys, content, force):
    """``optima --out FILE`` over an existing file: a file that is not a dataset is refused and
    left as it was; a dataset keeps its records (a resumed run only appends). With --force the
    file is emptied first (under its lock)."""
    task = tmp_path / "t.json"
    task.write_text('{"wrenches": [[0, 0, 9, 0, 0, 0]]}')
    out = tmp_path / "out.jsonl"
    out.write_bytes(content)
    argv = ["optima", "--tasks", str(task), "--out", str(out), "--n-max", "2", "--workers", "1"]
    code, _, err = run_main(capsys, [*argv, "--quiet", *(["--force"] if force else [])])
    assert code in (0, 2) and "Traceback" not in err, err
    after = out.read_bytes()
    if code == 2:
        assert after == content and "--out" in err or str(out) in err, err
    elif not force:
        complete = content[: content.rfind(b"\n") + 1]
        assert after.startswith(complete) and len(after.splitlines()) >= 1
    else:
        assert len(after.splitlines()) == 1


DESTINATIONS = st.sampled_from(["/dev/null", "/dev/full", "file", "file/sub", "taken"])


MOVED = (
    "oracle", "search", "scaling", "anytime", "scale", "scale_suites", "level_bounds",
    "distributed", "heterogeneous", "env", "paper", "coldstart", "dynamics",
)  # fmt: skip
"""The benchmarks that were ``modquad bench NAME`` commands (issue 33 moved them out of the
package to ``python -m benchmarks.NAME``): their parsers share ``benchmarks.common``."""
WRITERS = sorted({*MOVED, "agents"} - {"scale_suites"})
"""The benchmarks that write reports into ``--out`` (``scale_suites`` writes package data), and
``modquad score`` (``agents``)."""


@FUZZ
@given(what=st.sampled_from(WRITERS), where=DESTINATIONS, content=st.binary(max_size=50))
def test_bench_outputs_refuse_before_work(tmp_path, capsys, monkeypatch, what, where, content):
    """Every benchmark refuses a device, a file, a path below a file and a folder holding its
    reports (no --force) while parsing: exit 2, one error line, nothing changed."""
    assume(not (what == "distributed" and where == "taken"))  # needs Ray before its reports
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_bytes(content)
    taken = tmp_path / "taken"
    taken.mkdir(exist_ok=True)
    for name in _report_names(what):
        (taken / name).write_bytes(content)
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    out = where if where.startswith("/") else str(tmp_path / where)
    code, _, err = run_bench(capsys, [what, "--out", out, *_cheap(what)])
    assert code == 2, err
    assert "Traceback" not in err and "error: " in err.strip().splitlines()[-1], err
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before


def _report_names(what: str) -> tuple[str, ...]:
    """The files a benchmark writes into --out (what its parser refuses to replace)."""
    from benchmarks.paper import OUTPUTS
    from modquad_gym.scoring.agents import REPORT_FILES

    names = {
        "oracle": ("oracle_benchmark.md",),
        "search": ("search_benchmark.csv",),
        "scaling": ("search_scaling.md",),
        "distributed": ("distributed.md",),
        "env": ("env_benchmark.md",),
        "heterogeneous": ("heterogeneous.png",),
        "paper": OUTPUTS[:1],
        "agents": REPORT_FILES[:1],
        "coldstart": ("coldstart.csv",),
        "anytime": ("anytime.md",),
        "scale": ("report.md",),
        "dynamics": ("dynamics.csv",),
    }
    if what == "level_bounds":
        from modquad_gym import TModule
        from modquad_gym.search.bounds import module_digest

        return (f"{module_digest(TModule())}.npz",)
    if what not in names:
        pytest.fail(f"bench {what}: name the reports it writes here (and in its outputs=)")
    return names[what]


def _cheap(what: str) -> list[str]:
    """Options that keep a benchmark small in case it ever started (it must not)."""
    return {"agents": ["--limit", "1", "--methods", "greedy"]}.get(what, [])
