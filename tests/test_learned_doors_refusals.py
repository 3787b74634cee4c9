"""The learned designer's doors refuse in one line, before any work, in each door's words
(review 27): ``train.py``'s ``--n-max`` beyond the expert search's reach before any folder is
claimed (and a refusal from inside training leaves nothing behind), the Python scoring door
(``run_benchmark``) refuses what ``modquad score`` refuses, ``--option KEY=none`` means none of it
or is refused, ``--certificate``'s advice fits the method, argparse's refusals are one line, and
a path handed to ``solve`` is named as one."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest

from modquad_gym.cli import main
from modquad_gym.methods import REGISTRY

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def planted6(tmp_path_factory):
    """``modquad task generate --kind planted --seed 1 --n-modules 6`` (the review's t.json): six
    modules are optimal, ppo answers seven (not certified: its bound is six); the task and its
    file."""
    from modquad_gym.tasks import generated_task

    task = generated_task("planted", 1, "total", None, 6)
    path = tmp_path_factory.mktemp("planted6") / "t.json"
    task.save(path)
    return task, path


def one_error_line(err: str, prog: str) -> str:
    """The one line of ``err``: ``PROG: error: ...``, no usage block, no traceback."""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"{prog}: error: "), err
    return lines[0]


# --- 1. train.py: --n-max beyond the expert's search, before any folder -------------------------


@pytest.fixture()
def train_argv(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return ["--out", str(tmp_path / "r1"), "--tensorboard", str(tmp_path / "tb1"),
            "--no-progress", "--no-report"]  # fmt: skip


BEYOND = [
    (["--tier", "mixed", "--n-max", "12"], "--n-max 12:", "mixed tier's 3 module types", 9),
    (["--tier", "mixed", "--n-max", "10"], "--n-max 10:", "mixed tier's 3 module types", 9),
    (["--n-max", "17"], "--n-max 17:", "search can finish:", 16),
    (["--tier", "fault", "--n-max", "20"], "--n-max 20:", "search can finish:", 16),
    (["--tier", "dynamic", "--n-max", "40"], "--n-max 40:", "depend on the structure", 14),
    (["--tier", "dynamic", "--n-max", "15"], "--n-max 15:", "depend on the structure", 14),
]


@pytest.mark.parametrize("argv, said, why, reach", BEYOND, ids=[" ".join(b[0]) for b in BEYOND])
def test_an_n_max_beyond_the_experts_search_is_refused_before_any_folder(
    tmp_path, capsys, train_argv, argv, said, why, reach
):
    """Refused while the options are read, in the flag's words; no run or log folder made (the
    refusal used to come from inside training, after both were claimed)."""
    from agents.cli import main as train

    with pytest.raises(SystemExit) as stop:
        train([*train_argv, *argv])
    assert stop.value.code == 2
    line = one_error_line(capsys.readouterr().err, "python train.py")
    assert line.startswith(f"python train.py: error: {said} beyond what the expert's exhaustive")
    assert why in line and f"at most {reach} modules" in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_the_python_training_door_refuses_it_in_the_same_words(tmp_path):
    from agents.config import TrainConfig
    from agents.training import check_start

    config = TrainConfig(out=tmp_path / "r", tier="mixed", n_max=10, tensorboard=tmp_path / "tb")
    with pytest.raises(ValueError, match=r"^--n-max 10: beyond what the expert's exhaustive"):
        check_start(config)


@pytest.mark.parametrize("argv", [["--n-max", "16"], ["--tier", "mixed", "--n-max", "9"]])
def test_an_n_max_the_expert_finishes_is_not_refused(train_argv, argv):
    """At the reach itself the exhaustive search certifies the tier's validation tasks (the 100
    of --n-eval: 4 s on the current tier at 16, 24 s on the mixed tier at 9, 2 cores): left to
    train."""
    from agents.cli import parse_args

    assert parse_args([*train_argv, *argv]).config.max_modules == int(argv[-1])


def test_the_reach_is_the_one_the_search_refuses_beyond():
    """``exhaustive_reach`` is the search's own limit: the typed search takes n_max at the
    reach and refuses one more (one type on self-weight tasks: the counted levels end at 14)."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.search.problem import SearchProblem
    from modquad_gym.search.typed import check_pair_budget, exhaustive_reach

    assert [exhaustive_reach(k) for k in (1, 2, 3)] == [14, 11, 9]
    assert exhaustive_reach(1, shape_only=True) == 16
    task = [[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]
    for k in (1, 2, 3):
        types = palette("t45,t45m,flat")[:k]
        reach = exhaustive_reach(k)
        check_pair_budget(SearchProblem(task, n_max=reach, modules=types, kind="external"), 1)
        beyond = SearchProblem(task, n_max=reach + 1, modules=types, kind="external")
        with pytest.raises(ValueError, match=f"at most {reach} modules"):
            check_pair_budget(beyond, 1)


def test_a_refusal_inside_training_leaves_no_record_to_block_the_same_command(
    tmp_path, capsys, train_argv, monkeypatch
):
    """A ValueError from inside training, after the folders were claimed and the log folder's
    ``train/`` made, leaves neither the run folder's record (of files never written) nor the
    empty ``train/``: the same command is refused again for its own reason, not because the
    folder "already holds train"."""
    pytest.importorskip("sb3_contrib")
    from agents import cli
    from agents.training import _run_folders
    from modquad_gym.core.interrupts import run_command

    def refused_inside(config):
        _run_folders(config)  # what training makes first: the run folder and its train/
        raise ValueError("refused inside training")

    monkeypatch.setattr(cli, "train", refused_inside)
    for _ in range(2):
        assert run_command(cli.main, "python train.py", train_argv) == 2
        err = capsys.readouterr().err
        assert err == "python train.py: error: refused inside training\n", err
        assert sorted(p.name for p in tmp_path.iterdir()) == []


# --- 2. run_benchmark refuses what modquad score refuses, in Python's words ---------------------


@pytest.fixture(scope="module")
def suites():
    from modquad_gym.tasks import load_suite

    path = ROOT / "modquad_gym" / "data" / "suites" / "heldout_paper.json"
    return {"heldout_paper": load_suite(path)[:1]}


PYTHON_REFUSALS = [
    (["ppo"], {"seed": 3}, "seed=3: no method scored takes a seed"),
    (["ppo-guided"], {"seed": 1}, "seed=1: no method scored takes a seed"),
    (["ppo-guided"], {"seed": -1}, "seed must be >= 0, got -1"),
    (["greedy"], {"model": Path("nonexistent.zip")}, "model='nonexistent.zip': not used: no "
     "learned method"),
    (["greedy"], {"trust_model": True}, "trust_model=True: not used: no learned method"),
    (["ppo"], {"tier": "bogus"}, "tier='bogus': unknown tier; choose one of current"),
]  # fmt: skip


@pytest.mark.parametrize("methods, given, words", PYTHON_REFUSALS,
                         ids=[f"{m[0]} {g}" for m, g, _ in PYTHON_REFUSALS])  # fmt: skip
def test_run_benchmark_refuses_what_the_command_line_refuses(suites, methods, given, words):
    from modquad_gym.scoring.agents import run_benchmark

    with pytest.raises(ValueError) as exc:
        run_benchmark(suites, methods, progress=False, **given)
    assert str(exc.value).startswith(words) and "--" not in str(exc.value), exc.value


def test_run_benchmark_names_a_model_file_in_pythons_words(suites, tmp_path):
    from modquad_gym.scoring.agents import run_benchmark

    bad = tmp_path / "notzip.zip"
    bad.write_text("not a zip")
    with pytest.raises(ValueError, match=f"^model {bad}: not a MaskablePPO model"):
        run_benchmark(suites, ["ppo"], model=bad, progress=False)


def test_run_benchmark_takes_a_seed_a_method_draws_with(suites):
    from modquad_gym.scoring.agents import run_benchmark

    (row,) = run_benchmark(suites, ["ppo-k2"], seed=3, progress=False)
    assert row.method == "ppo-k2" and row.success


@pytest.fixture()
def score_line(tmp_path, capsys, monkeypatch):
    """The error line of ``modquad score ARGV`` (nothing scored, no report folder)."""

    def refuse(*args, **kwargs):
        raise AssertionError("the work started")

    monkeypatch.setattr("modquad_gym.scoring.agents.run_benchmark", refuse)

    def run(*argv: str) -> str:
        code = main(["score", "--limit", "1", "--no-progress", "--out", str(tmp_path / "rep"),
                     *argv])  # fmt: skip
        err = capsys.readouterr().err
        assert code == 2 and not (tmp_path / "rep").exists(), err
        return one_error_line(err, "modquad")

    return run


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--methods", "ppo", "--seed", "3"], "--seed 3: no method scored takes a seed"),
        (["--methods", "greedy", "--model", "x.zip"], "--model x.zip: not used: no learned"),
        (["--methods", "greedy", "--trust-model"], "--trust-model: not used: no learned"),
        (["--methods", "greedy", "--train-dir", "run"], "--train-dir run: not used: no learned"),
        (["--tier", "bogus"], "--tier: unknown tier 'bogus'"),
    ],
)
def test_modquad_score_keeps_the_flags_words(score_line, argv, words):
    assert score_line(*argv).startswith(f"modquad: error: {words}")


# --- 3. --option KEY=none: none of it, or refused ----------------------------------------------


@pytest.mark.parametrize(
    "method, text, value",
    [
        ("ppo", "extra_fallbacks=none", ()),
        ("ppo", "extra_fallbacks=NONE", ()),
        ("ppo", "extra_fallbacks=", ()),
        ("ppo", "top_k=none", None),
        ("ppo-guided", "top_k=none", None),
    ],
)
def test_none_on_the_command_line_means_none_of_it(method, text, value):
    assert REGISTRY[method].options.parse(method, text) == (text.split("=")[0], value)


@pytest.mark.parametrize(
    "method, key",
    [("ppo", "fallback"), ("ppo-guided", "fallback"), ("ppo-guided", "budget"),
     ("anytime", "seed"), ("genetic", "penalty")],
)  # fmt: skip
def test_none_that_would_only_stand_for_the_default_is_refused(method, key):
    with pytest.raises(ValueError) as exc:
        REGISTRY[method].options.parse(method, f"{key}=none")
    assert str(exc.value) == (f"--option {key}=none: {key} takes no none (its None only stands "
                              f"for its default, which leaving {key} out gives)")  # fmt: skip
    with pytest.raises(ValueError, match=f"{key} takes an? [a-z]+, got 'x'$"):  # no "or none"
        REGISTRY[method].options.parse(method, f"{key}=x")


def test_extra_fallbacks_none_is_the_single_pass_by_both_doors(planted6, capsys):
    """``--option extra_fallbacks=none`` is Python's ``extra_fallbacks=()`` (the single pass),
    not the default's extra passes (ppo's default evaluates 11 structures on this task, the
    single pass 7)."""
    from modquad_gym.solvers import make_solver

    task, path = planted6
    single = make_solver("ppo", extra_fallbacks=()).solve(task)
    default = make_solver("ppo").solve(task)
    assert single.evaluated < default.evaluated  # the default runs its extra passes here
    for option in ("extra_fallbacks=none", "extra_fallbacks="):
        code = main(["solve", "--task", str(path), "--method", "ppo", "--option", option,
                     "--json"])  # fmt: skip
        line = json.loads(capsys.readouterr().out)
        assert code == 0
        assert [line[k] for k in ("cells", "evaluated", "oracle_calls")] == [
            [list(c) for c in single.structure.cells],
            single.evaluated,
            single.oracle_calls,
        ]


# --- 4. --certificate's advice fits the method ------------------------------------------------


def test_a_learned_answer_not_certified_is_not_told_to_wait_longer(planted6, tmp_path, capsys):
    out = tmp_path / "c.json"
    code = main(["solve", "--task", str(planted6[1]), "--method", "ppo", "--time-limit", "3000",
                 "--certificate", str(out), "--quiet"])  # fmt: skip
    line = one_error_line(capsys.readouterr().err, "modquad")
    assert code == 2 and not out.exists()
    assert "is not certified" in line and "--time-limit" not in line, line
    assert line.endswith("give --method anytime (the default, which certifies where it "
                         "finishes) or --method exhaustive")  # fmt: skip


@pytest.mark.parametrize(
    "method, n_max, modules, advice",
    [("anytime", 64, None, "give a longer --time-limit"),
     ("milp", 7, None, "give a longer --time-limit or --method exhaustive"),
     ("anytime", 12, "t45,t45m", "give a longer --time-limit"),
     ("ppo", 7, None, "give --method anytime (the default, which certifies where it finishes) "
                      "or --method exhaustive"),
     ("ppo-guided", 64, None, "give --method anytime (the default, which certifies where it "
                              "finishes)"),
     ("beam", 16, None, "give --method anytime (the default, which certifies where it finishes) "
                        "or --method exhaustive")],
)  # fmt: skip
def test_the_certificate_advice_names_what_can_certify_there(
    planted6, method, n_max, modules, advice
):
    """A certifying, timed search that ends uncertified ran out of time (anytime stops near 0.9
    of its limit, so no ratio of the seconds says it); the exhaustive search is offered only
    within its reach (16 modules of one type, 11 of two)."""
    from modquad_gym.cli.solve_outputs import certifying_advice

    args = SimpleNamespace(method=method, n_max=n_max, modules=modules, cells=None)
    assert certifying_advice(args, planted6[0]) == advice


# --- 5. argparse's refusals are one line ------------------------------------------------------


@pytest.mark.parametrize(
    "argv, prog",
    [
        (["solve", "--task", "t.json", "--method", "ppo", "--time-limit", "nan"], "modquad solve"),
        (["solve", "--task", "t.json", "--seed", "-1"], "modquad solve"),
        (["solve", "--task", "t.json", "--method", "ppo-k-1"], "modquad solve"),
        (["score", "--n-max", "0"], "modquad score"),
        (["bogus"], "modquad"),
        (["solve"], "modquad solve"),
    ],
)
def test_an_option_the_parser_refuses_is_one_line(capsys, argv, prog):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    one_error_line(capsys.readouterr().err, prog)


def test_train_and_the_scripts_refuse_an_option_in_one_line(capsys):
    from agents.cli import parse_args
    from benchmarks.oracle import main as oracle
    from modquad_gym.scoring.seeds import main as seeds

    calls = [(lambda: parse_args(["--n-max", "x"]), "python train.py"),
             (lambda: oracle(["--bogus"]), "python -m benchmarks.oracle"),
             (lambda: seeds(["--bogus"]), "python -m modquad_gym.scoring.seeds")]  # fmt: skip
    for call, prog in calls:
        with pytest.raises(SystemExit) as stop:
            call()
        assert stop.value.code == 2
        one_error_line(capsys.readouterr().err, prog)


def test_every_parser_is_the_one_line_parser():
    """No command builds argparse's own parser: each builds ``OneLineParser`` (its subparsers
    follow), so no refusal prints the usage block."""
    built = [f"{path.relative_to(ROOT)}:{n}"
             for folder in ("modquad_gym", "agents", "benchmarks", "docs", "examples")
             for path in sorted((ROOT / folder).rglob("*.py"))
             for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
             if "ArgumentParser(" in line]  # fmt: skip
    assert built == [], built


# --- 6. a path handed to solve -----------------------------------------------------------------


@pytest.mark.parametrize("given", ["t.json", Path("t.json"), b"t.json"])
def test_a_path_given_as_the_task_names_what_to_give(given):
    import modquad_gym as mq
    from modquad_gym.solvers import make_solver

    for call in (make_solver("greedy").solve, lambda t: mq.exhaustive_search(t, n_max=3)):
        with pytest.raises(ValueError) as exc:
            call(given)
        assert "a path is not a task; give modquad_gym.tasks.load_task(path)" in str(exc.value), (
            exc.value
        )
        assert "dtype" not in str(exc.value)
