"""The benchmark scripts' entry points: options checked when the command line is read (a value
given twice, a count out of range, nothing to run), before any work. The parser tests catch each
script's parser at its ``parse_args`` call, so they never start a search, whatever the script
does after it."""

from __future__ import annotations

import argparse
import importlib

import numpy as np
import pytest

from benchmarks.common import run_script


class _ParserCaughtError(Exception):
    """Raised in place of ``parse_args``: the parser is built, no work has started."""


def parser_of(monkeypatch, name: str, argv=()) -> argparse.ArgumentParser:
    """The parser ``benchmarks.NAME``'s ``main`` (or module NAME's, with a dot) builds, caught
    at its ``parse_args``."""
    caught = {}

    def catch(self, args=None, namespace=None):
        caught["parser"] = self
        raise _ParserCaughtError

    main = importlib.import_module(name if "." in name else f"benchmarks.{name}").main
    with monkeypatch.context() as m:
        m.setattr(argparse.ArgumentParser, "parse_args", catch)
        with pytest.raises(_ParserCaughtError):
            main(list(argv))
    return caught["parser"]


def refused(capsys, parser: argparse.ArgumentParser, argv: list[str]) -> str:
    """``parser`` refuses ``argv``: exit 2 and one error line, which is returned."""
    with pytest.raises(SystemExit) as stop:
        parser.parse_args(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    return err.strip().splitlines()[-1]


TWICE = [
    ("anytime", ["--sizes", "16", "24", "16"], "--sizes: 16"),
    ("distributed", ["--search-n-max", "13", "13"], "--search-n-max: 13"),
    ("dynamics", ["--circle-speeds", "1", "1.0"], "--circle-speeds: 1"),
    ("dynamics", ["--eight-speeds", "2", "2"], "--eight-speeds: 2"),
    ("dynamics", ["--push-forces", "4", "4"], "--push-forces: 4"),
    ("env", ["--sizes", "1", "1"], "--sizes: 1"),
    ("env", ["--scale", "16", "16"], "--scale: 16"),
    ("env", ["--lookahead-n-max", "7", "7"], "--lookahead-n-max: 7"),
    ("fallback", ["--bands", "16", "16"], "--bands: 16"),
    ("fallback", ["--families", "mixed", "mixed"], "--families: mixed"),
    ("fallback", ["--fallbacks", "0.6", "0.60"], "--fallbacks: 0.6"),
    ("fallback", ["--k", "8", "8"], "--k: 8"),
    ("fallback", ["--budgets", "auto", "auto"], "--budgets: auto"),
    ("fallback", ["--extra-fallbacks", "none", "none"], "--extra-fallbacks: none"),
    ("fault_delay", ["--sources", "paper", "paper"], "--sources: paper"),
    ("fault_delay", ["--margins", "0", "0"], "--margins: 0"),
    ("fault_delay", ["--delays", "0.01", "0.010"], "--delays: 0.01"),
    ("fault_detector", ["--suites", "fault_rotor", "fault_rotor"], "--suites: fault_rotor"),
    ("fault_detector", ["--designs", "rotor", "rotor"], "--designs: rotor"),
    ("fault_rotor2", ["--suites", "fault_rotor", "fault_rotor"], "--suites: fault_rotor"),
    ("faults", ["--suites", "fault_rotor", "fault_rotor"], "--suites: fault_rotor"),
    ("faults", ["--designs", "intact", "intact"], "--designs: intact"),
    ("leaderboard", ["--tiers", "current", "current"], "--tiers: current"),
    ("leaderboard", ["--seeds", "1", "1"], "--seeds: 1"),
    ("lookahead_top_k", ["--bands", "16", "16"], "--bands: 16"),
    ("lookahead_top_k", ["--families", "planted", "planted"], "--families: planted"),
    ("lookahead_top_k", ["--k", "4", "4"], "--k: 4"),
    ("oracle", ["--modules", "7,16,7"], "--modules: 7 is given twice in 7,16,7"),
    ("oracle_accuracy", ["--seeds", "0", "0"], "--seeds: 0"),
    ("prune", ["--bands", "16", "16"], "--bands: 16"),
    ("prune", ["--methods", "greedy", "greedy"], "--methods: greedy"),
    ("scale", ["--bands", "16", "16"], "--bands: 16"),
    ("scale", ["--families", "planted", "planted"], "--families: planted"),
    ("scale", ["--methods", "greedy", "greedy"], "--methods: greedy"),
    ("scale_models", ["--models", "m=x.zip", "--bands", "16", "16"], "--bands: 16"),
    ("scale_seeds", ["--bands", "16", "16"], "--bands: 16"),
    ("scale_suites", ["--bands", "16", "16"], "--bands: 16"),
]


@pytest.mark.parametrize("name, argv, says", TWICE, ids=[f"{n}{a[0]}" for n, a, _ in TWICE])
def test_a_value_given_twice_is_refused_naming_the_option_and_the_value(
    monkeypatch, capsys, tmp_path, name, argv, says
):
    """A list option's value given twice would be run twice and counted twice in the report's
    totals (two rows of one task, "tasks 2" for one): argparse refuses it in one line naming
    the option and the value, exit 2."""
    parser = parser_of(monkeypatch, name)
    last = refused(capsys, parser, [*argv, "--out", str(tmp_path / "out")])
    assert last.endswith(f"error: argument {says}" + ("" if "given" in says else " is given twice"))
    assert not (tmp_path / "out").exists()


def test_a_run_folder_given_twice_is_refused_however_spelt(monkeypatch, capsys, tmp_path):
    """rl_stage's runs are compared by their resolved folder."""
    (tmp_path / "run").mkdir()
    (tmp_path / "x").mkdir()
    again = tmp_path / "x" / ".." / "run"
    parser = parser_of(monkeypatch, "rl_stage")
    last = refused(capsys, parser, [str(tmp_path / "run"), str(again)])
    assert last.endswith(f"error: argument RUN: {again} is given twice")


def test_scale_suites_names_its_options_when_a_suite_file_appears_during_the_run(
    monkeypatch, capsys, tmp_path
):
    """A suite file that appears in --out while the bounds are searched (another run) is refused
    in the command's words (--out, --force), not the Python API's (path, force=True); with
    --force it is replaced."""
    from benchmarks import scale_suites
    from modquad_gym.tasks import TaskRequirement

    out = tmp_path / "suites"

    def build_band(band, per_family, time_limit, validation=False):
        out.mkdir(exist_ok=True)
        (out / f"scale_{band}.json").write_text("another run's")
        return [TaskRequirement(np.array([[0, 0, 1.0, 0, 0, 0]]), name=f"t{band}")]

    monkeypatch.setattr(scale_suites, "build_band", build_band)
    assert run_script("scale_suites", ["--bands", "16", "--out", str(out)]) == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"error: --out: {out / 'scale_16.json'} exists (use --force to replace it)" in last
    assert (out / "scale_16.json").read_text() == "another run's"
    assert run_script("scale_suites", ["--bands", "16", "--out", str(out), "--force"]) == 0
    assert '"name": "scale_16"' in (out / "scale_16.json").read_text()


OUT_OF_RANGE = [
    ("lookahead_top_k", ["--per-family", "-1"], "--per-family: must be in 0..100, got -1"),
    ("lookahead_top_k", ["--small", "-1"], "--small: must be in 0..10000, got -1"),
    ("lookahead_top_k", ["--bands", "-1"], "--bands: must be in 2..128, got -1"),
    ("lookahead_top_k", ["--k", "0"], "--k: must be in 1..1000000, got 0"),
    ("lookahead_top_k", ["--time-limit", "nan"], "--time-limit: expected a finite number"),
    ("dynamics", ["--circle-speeds", "-1"], "--circle-speeds: must be > 0, got -1"),
    ("dynamics", ["--eight-speeds", "1", "0"], "--eight-speeds: must be > 0, got 0"),
    ("dynamics", ["--push-forces", "0"], "--push-forces: must be > 0, got 0"),
]


@pytest.mark.parametrize(
    "name, argv, says", OUT_OF_RANGE, ids=[" ".join(a) for _, a, _ in OUT_OF_RANGE]
)
def test_counts_and_speeds_out_of_range_are_refused_naming_the_option(
    monkeypatch, capsys, tmp_path, name, argv, says
):
    """lookahead_top_k's counts, bands, shortlists and time limit, and dynamics' speeds and
    forces, are checked as the other benchmarks check theirs: the option, the range, the value
    (a negative --per-family ran with no scale task; the others failed after the model load or
    in the library's words: "top_k must be >= 1", "speed must be positive")."""
    parser = parser_of(monkeypatch, name)
    last = refused(capsys, parser, [*argv, "--out", str(tmp_path / "out")])
    assert f"error: argument {says}" in last


@pytest.mark.parametrize(
    "name, argv, says",
    [
        ("lookahead_top_k", ["--bands", "--small", "0"], "nothing to run: give --bands"),
        ("lookahead_top_k", ["--per-family", "0", "--small", "0"], "nothing to run"),
        ("dynamics", ["--circle-speeds", "--eight-speeds", "--push-forces"],
         "nothing to run: give --circle-speeds, --eight-speeds or --push-forces"),
        ("dynamics", ["--circle-speeds", "--eight-speeds", "1e6", "--push-forces"],
         "--eight-speeds 1e+06: ramp: "),
    ],
)  # fmt: skip
def test_nothing_to_run_or_a_motion_that_cannot_be_built_is_one_line(
    capsys, tmp_path, name, argv, says
):
    """An empty plan (it gave a traceback: an empty table) and a motion the library refuses are
    one line naming the options, exit 2, before any search, with nothing written."""
    out = tmp_path / "out"
    assert run_script(name, [*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert says in err.strip().splitlines()[-1] and "Traceback" not in err, err
    assert not out.exists()


class _MadeByError(Exception):
    """Stops heterogeneous's report at its "Made by" line."""


def test_heterogeneous_names_the_command_as_run(monkeypatch, tmp_path):
    """The report's "Made by" is the command as run, --mujoco included: it named --tasks, --seed
    and --n-max only, so `--mujoco 0`'s report (no MuJoCo section) named a command that adds
    one. The measurements are replaced by stubs: only the command line is checked."""
    from benchmarks import heterogeneous, heterogeneous_report

    for name in ("exhaustive_search", "task_sets", "compare", "summary", "worst_case", "figure"):
        monkeypatch.setattr(heterogeneous, name, lambda *a, **k: [])
    monkeypatch.setattr(heterogeneous, "mujoco_rows", lambda *a: pytest.fail("MuJoCo ran"))
    said = []

    def made_by(command, *rest):
        said.append(command)
        raise _MadeByError

    monkeypatch.setattr(heterogeneous_report, "made_by", made_by)
    argv = ["--mujoco", "0", "--tasks", "2", "--out", str(tmp_path / "h")]
    with pytest.raises(_MadeByError):
        heterogeneous.main(argv)
    assert said == ["python -m benchmarks.heterogeneous " + " ".join(argv)]


def test_codebase_names_its_own_out(monkeypatch, tmp_path):
    """codebase's report named `--out results/codebase --force` whatever it was given."""
    from benchmarks import codebase

    total = {"folder": "total", "files": 1, "lines": 1, "docstrings": 0, "blank": 0, "code": 1}
    monkeypatch.setattr(codebase, "line_counts", lambda: [total])
    monkeypatch.setattr(codebase, "kind_branches", lambda: [])
    monkeypatch.setattr(codebase, "solve_path_files", lambda: [])
    out = tmp_path / "my report"
    assert codebase.main(["--out", str(out)]) == 0
    text = (out / "codebase.md").read_text()
    assert f"Made by `python -m benchmarks.codebase --out '{out}'` on " in text


def test_the_command_as_run_is_the_argv_given_quoted(monkeypatch):
    """A Python caller's argv (even an empty one) is the command, not the test runner's."""
    from benchmarks.common import command_as_run

    monkeypatch.setattr("sys.argv", ["pytest", "-k", "x"])
    assert command_as_run("faults", []) == "python -m benchmarks.faults"
    assert command_as_run("faults") == "python -m benchmarks.faults -k x"
    assert command_as_run("scale", ["--out", "a b"]) == "python -m benchmarks.scale --out 'a b'"


def test_fault_rotor2_oracle_only_needs_its_minima_before_any_work(monkeypatch, capsys, tmp_path):
    """--oracle-only keeps minima.csv: without one it is refused at once naming the option (it
    timed the oracle first, then said "minima.csv: no rows to write" and left an empty folder)."""
    from benchmarks import fault_rotor2

    monkeypatch.setattr(fault_rotor2, "oracle_speed", lambda *a: pytest.fail("the timing ran"))
    for out in (tmp_path / "new", tmp_path):  # a folder to be made, and an existing one
        assert run_script("fault_rotor2", ["--oracle-only", "--out", str(out)]) == 2
        last = capsys.readouterr().err.strip().splitlines()[-1]
        assert f"error: --oracle-only: no minima.csv in {out}" in last
    assert not (tmp_path / "new").exists() and not list(tmp_path.iterdir())


def test_fallback_with_nothing_to_run_is_refused_before_the_model_loads(
    monkeypatch, capsys, tmp_path
):
    """--bands with no value and --small 0: one line naming the options (the model was loaded,
    then "rows.csv: no rows to write")."""
    from benchmarks import fallback

    monkeypatch.setattr(fallback, "measure", lambda *a: pytest.fail("the measurement started"))
    out = tmp_path / "fb"
    assert run_script("fallback", ["--bands", "--small", "0", "--out", str(out)]) == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert "error: nothing to run: give --bands or --small > 0" in last
    assert not out.exists()


def test_fallback_model_is_read_before_the_measurement(monkeypatch, capsys, tmp_path):
    """--model names a model file read before any task is drawn (a missing one: one line
    naming the option); with --rows (no solving) it is refused."""
    from benchmarks import fallback

    monkeypatch.setattr(fallback, "measure", lambda *a: pytest.fail("the measurement started"))
    out, missing = tmp_path / "fb", tmp_path / "none.zip"
    assert run_script("fallback", ["--model", str(missing), "--out", str(out)]) == 2
    assert f"error: --model {missing}: " in capsys.readouterr().err.strip().splitlines()[-1]
    rows = tmp_path / "rows.csv"
    rows.write_text("band,family,task,method,found,seconds,optimum\n")
    shipped = "modquad_gym/data/models/ppo_default/model.zip"
    assert run_script("fallback", ["--model", shipped, "--rows", str(rows), "--out", str(out)]) == 2
    assert "error: --model: --rows re-renders without solving" in capsys.readouterr().err
    assert not out.exists()


def test_fallback_model_reaches_every_learned_variant(tmp_path):
    """The model given is each learned variant's ``model`` option; the rival takes none."""
    from benchmarks import fallback

    model = "modquad_gym/data/models/ppo_default/model.zip"
    args = fallback.parse_args(["--model", model, "--bands", "--small", "2", "--fallbacks", "0",
                                "--k", "8", "--extra-fallbacks", "none", "1",
                                "--out", str(tmp_path)])  # fmt: skip
    found = fallback.variants(args)
    assert [name for name, _, _ in found] == ["ppo-top8-f0-x", "ppo-top8-f0-x1", "greedy"]
    assert all(o["model"] == args.model for _, _, o in found[:-1]) and found[-1][2] == {}


def test_derivative_agreement_reads_the_shipped_suite_from_any_folder(
    monkeypatch, capsys, tmp_path
):
    """The dynamic suite is the package's file, read before the grid's work: from another
    working folder it failed after the grid ("suite file not found: modquad_gym/data/...").
    The populations are stubbed: only where the suite is read from is checked."""
    from benchmarks import derivative_agreement as da

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(da, "grid", lambda: (0.0, 0.0, 0, 0, 0.0))
    monkeypatch.setattr(da, "wide", lambda n: (0.0, 0, 0.0, 0.0))
    monkeypatch.setattr(da, "milliseconds", lambda: 0.0)
    monkeypatch.setattr(da, "excess", lambda data: 0.0)
    assert da.main(["--draws", "1", "--wide", "1"]) == 0
    assert "suite: 60 tasks" in capsys.readouterr().out


def _parsers(monkeypatch):
    """(name, parser) of every benchmark script and of ``agents.expert_iteration``."""
    from benchmarks.common import scripts

    names = [f"benchmarks.{name}" for name in scripts()] + ["agents.expert_iteration"]
    for name in names:
        yield name, parser_of(monkeypatch, name)


def test_help_states_every_default(monkeypatch):
    """Each option with a default says it in --help (env, fallback, lookahead_top_k,
    scale_suites, oracle, scaling, search, paper, coldstart, fault_delay, figures, faults,
    codebase and expert_iteration left some out, some options had no help at all); a list
    default is written as it is typed."""
    silent = (None, False, "", [], (), argparse.SUPPRESS)
    missing = []
    for name, parser in _parsers(monkeypatch):
        formatter = parser._get_formatter()
        for action in parser._actions:
            if not action.option_strings or any(action.default is s or action.default == s
                                                for s in silent):  # fmt: skip
                continue
            text = formatter._expand_help(action) if (action.help or "").strip() else ""
            if "default" not in text.lower():
                missing.append(f"{name} {action.option_strings[0]}: {text!r}")
    assert not missing, "\n".join(missing)
    env = dict(_parsers(monkeypatch))["benchmarks.env"].format_help()
    assert "(default 1 8 32 80 200)" in " ".join(env.split())


def test_usage_lines_in_docstrings_give_the_defaults(monkeypatch):
    """A docstring's ``[--option VALUE]`` is the option's default (search's said --tasks 5; the
    code's is 4). Placeholders (upper case, ``a|b``, ``...``) are not values."""
    import re

    def shown(value) -> str:  # as a command line writes a value
        if isinstance(value, tuple):
            return ",".join(map(shown, value))
        return f"{value:g}" if isinstance(value, float) else "auto" if value is None else str(value)

    wrong = []
    for name, parser in _parsers(monkeypatch):
        doc = importlib.import_module(name).__doc__ or ""
        actions = {flag: a for a in parser._actions for flag in a.option_strings}
        for found in re.finditer(r"\[(--[a-z-]+)((?: [^\]\[\s-][^\]\[\s]*)+)\]", doc):
            flag, values = found.group(1), found.group(2).split()
            action = actions.get(flag)
            assert action is not None, f"{name}'s docstring names {flag}, not an option"
            if any(v.isupper() or "|" in v or v == "..." for v in values):
                continue
            many = isinstance(action.default, (list, tuple)) and action.nargs not in (None, "?")
            code = " ".join(map(shown, action.default)) if many else shown(action.default)
            if " ".join(values) != code:
                wrong.append(f"{name} {flag}: docstring {' '.join(values)}, code {code}")
    assert not wrong, "\n".join(wrong)


def test_scale_suites_help_gives_the_time_limit_it_accepts(monkeypatch):
    """--time-limit -1 is refused with "(0, 3600]": the help says so."""
    text = " ".join(parser_of(monkeypatch, "scale_suites").format_help().split())
    assert "in (0, 3600] (default 10)" in text
