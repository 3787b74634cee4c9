"""Property tests over hostile input (issue 12): task files, command-line options, API arguments
and the oracle's numeric range.

Every property is the same contract: the command line exits 0 or 2 and never prints a traceback
(2 comes with an error line naming the file or option); the API raises ValueError (TypeError
where Python itself decides) naming the argument; nothing answers nonsense silently; every
example finishes within the hypothesis deadline. Examples are derandomised, so CI runs the same
cases every time.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import modquad_gym as mq
from benchmarks.reference_oracle import register
from modquad_gym import cli
from modquad_gym.oracle import BAND, TOL
from modquad_gym.tasks import TaskRequirement

register()  # "hrep", a cross-check method of the oracle's table, which these properties ask

ROOT = Path(__file__).resolve().parents[1]
SCREWDRIVER = str(ROOT / "examples" / "screwdriver.json")

DEEP = os.environ.get("MODQUAD_FUZZ_EXAMPLES")
"""Set MODQUAD_FUZZ_EXAMPLES=500 (say) for a deeper, randomised run; CI runs the fixed counts
(30, or 20 or 25 where a test says so)."""

FUZZ = settings(
    max_examples=int(DEEP) if DEEP else 30,
    deadline=timedelta(seconds=10),
    derandomize=not DEEP,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

HOSTILE = ["-1", "0", "nan", "inf", "-inf", "1e400", str(10**30), "", "ü", "1_0", "0x10", "1.5"]
"""Values no count, size or seed option takes (``0`` and ``1.5`` are fine for some reals)."""


@pytest.fixture(scope="module", autouse=True)
def _warm_up():
    """Compile the search's numba kernels once, outside the per-example deadline."""
    assert cli.main(["solve", "--task", SCREWDRIVER, "--n-max", "3", "--quiet"]) == 0


def run_main(capsys, argv: list[str]) -> tuple[int, str, str]:
    try:
        code = cli.main(argv)
    except SystemExit as exc:  # argparse: usage line and error line, exit 2
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def run_bench(capsys, argv: list[str]) -> tuple[int, str, str]:
    """``python -m benchmarks.NAME REST`` for ``argv`` = [NAME, *REST] in this process (NAME
    ``agents``: ``modquad score REST``)."""
    from benchmarks.common import run_script

    if argv[0] == "agents":
        return run_main(capsys, ["score", *argv[1:]])
    code = run_script(argv[0], argv[1:])
    out, err = capsys.readouterr()
    return code, out, err


def assert_clean_exit(code: int, err: str) -> None:
    """Exit 0 or 2, never a traceback; 2 ends with one error line."""
    assert code in (0, 2), (code, err)
    assert "Traceback" not in err, err
    if code == 2:
        last = err.strip().splitlines()[-1]
        assert last.startswith("modquad: error: ") or ": error: " in last, err


# ------------------------------------------------------------------ (a) task files
NUMBER = st.one_of(
    st.integers(-1000, 1000),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**400), max_value=10**400),
)
CELL = st.one_of(
    NUMBER, st.sampled_from(["1", "", None, True, False, [], {}, [1, 2], "nan", "1_0"])
)
ROW = st.one_of(
    st.lists(NUMBER, min_size=6, max_size=6),
    st.lists(CELL, min_size=0, max_size=8),
    CELL,
)
ROWS = st.one_of(st.lists(ROW, max_size=5), CELL)

JSON_DOC = st.one_of(
    st.fixed_dictionaries(
        {"wrenches": ROWS},
        optional={
            "f_max": CELL,
            "name": st.one_of(st.text(max_size=8), CELL),
            "kind": st.sampled_from(["total", "external", "bogus", 3]),
            "extra": CELL,
        },
    ),
    ROWS,
    st.recursive(
        st.none() | st.booleans() | NUMBER | st.text(max_size=5),
        lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=4), c, max_size=4),
        max_leaves=12,
    ),
)


@st.composite
def json_text(draw) -> str:
    text = json.dumps(draw(JSON_DOC), allow_nan=True)
    mutation = draw(st.sampled_from(["none", "cut", "insert", "bom"]))
    if mutation == "cut" and text:
        text = text[: draw(st.integers(0, len(text) - 1))]
    elif mutation == "insert":
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.sampled_from(list(",[]{}\"'x\x00 \ufeff"))) + text[at:]
    elif mutation == "bom":
        text = "\ufeff" + text
    return text


CSV_TOKEN = st.one_of(
    st.sampled_from(
        ["0", "1", "-3.5", "1e400", "nan", "inf", "1_0", "0x1", "", " ", "ü", "1,5", "+2", "1e-3"]
    ),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-(10**30), 10**30).map(str),
)


@st.composite
def csv_text(draw) -> str:
    rows = draw(st.lists(st.lists(CSV_TOKEN, min_size=4, max_size=8), max_size=5))
    sep = draw(st.sampled_from([",", ";", "\t", ", "]))
    header = draw(st.sampled_from([None, "fx,fy,fz,tx,ty,tz", "0,1,2,3,4,5", "a,b,c,d,e,f"]))
    lines = ([header] if header else []) + [sep.join(r) for r in rows]
    text = draw(st.sampled_from(["\n", "\r\n", "\r"])).join(lines)
    return ("\ufeff" if draw(st.booleans()) else "") + text


NPY_SHAPE = st.sampled_from([(2, 6), (1, 6), (6,), (0, 6), (3, 5), (2, 3, 6), ()])
NPY_DTYPE = st.sampled_from(["float64", "float32", "int64", "complex128", "bool", "U3", "object"])


def check_task_file(path: Path, capsys) -> None:
    """The file through the loader and through `modquad solve`: consistent, never a crash."""
    try:
        task = TaskRequirement.load(path)
    except ValueError as exc:
        task = None
        assert str(exc).strip(), "an empty error message"
    code, out, err = run_main(
        capsys, ["solve", "--task", str(path), "--n-max", "3", "--quiet", "--json"]
    )
    assert_clean_exit(code, err)
    if task is None:
        assert code == 2, out
        return
    W = task.wrenches  # what was accepted is a well-formed task, not a silent misread
    assert W.ndim == 2 and W.shape[1] == 6 and len(W) >= 1
    assert np.isfinite(W).all() and math.isfinite(task.f_max) and task.f_max > 0
    if code == 2:  # only absurd scales are refused after a clean load
        assert "beyond" in err, err
        return
    record = json.loads(out)
    if record["feasible"]:
        s = mq.Structure([tuple(c) for c in record["cells"]])
        assert mq.feasible(s.configuration_matrix(), W, task.f_max).all() or task.kind != "total"


@FUZZ
@given(data=st.binary(max_size=300), suffix=st.sampled_from([".json", ".csv", ".npy", ".txt"]))
def test_arbitrary_bytes_as_task_file(tmp_path, capsys, data, suffix):
    path = tmp_path / f"task{suffix}"
    path.write_bytes(data)
    check_task_file(path, capsys)


@FUZZ
@given(text=json_text())
def test_near_valid_json_task_file(tmp_path, capsys, text):
    path = tmp_path / "task.json"
    path.write_text(text, encoding="utf-8")
    check_task_file(path, capsys)


@FUZZ
@given(text=csv_text())
def test_near_valid_csv_task_file(tmp_path, capsys, text):
    path = tmp_path / "task.csv"
    path.write_bytes(text.encode("utf-8"))
    check_task_file(path, capsys)


@FUZZ
@given(shape=NPY_SHAPE, dtype=NPY_DTYPE, seed=st.integers(0, 2**16), special=st.booleans())
def test_npy_task_file(tmp_path, capsys, shape, dtype, seed, special):
    rng = np.random.default_rng(seed)
    arr = rng.normal(size=shape) * 3
    if special and arr.size:
        arr.flat[0] = rng.choice([np.nan, np.inf, 1e300])
    with np.errstate(invalid="ignore", over="ignore"):  # nan, inf, 1e300 cast: any value will do
        arr = arr.astype(dtype) if dtype != "object" else arr.astype(object)
    path = tmp_path / "task.npy"
    np.save(path, arr, allow_pickle=True)  # an object array is pickled: the loader must refuse
    check_task_file(path, capsys)
    if dtype == "object":
        with pytest.raises(ValueError):
            TaskRequirement.load(path)


@FUZZ
@given(wrenches=st.one_of(ROWS, st.lists(st.lists(NUMBER, min_size=6, max_size=6), max_size=4)))
def test_task_requirement_api(wrenches):
    """TaskRequirement(...) accepts a well-formed finite array or raises ValueError."""
    try:
        task = TaskRequirement(wrenches)
    except ValueError as exc:
        assert str(exc)
        return
    assert task.wrenches.shape[1] == 6 and np.isfinite(task.wrenches).all()


# ------------------------------------------------------------------ (b) command-line options
def _values(valid: list[str]) -> st.SearchStrategy[str]:
    return st.sampled_from(HOSTILE + valid)


SOLVE_OPTIONS = {
    "--n-max": _values(["1", "2", "3"]),
    "--method": st.sampled_from(["exhaustive", "centrosymmetric", "greedy", "random", "bogus", ""]),
    "--seed": _values(["0", "7", str(2**63 - 1)]),
    "--workers": _values(["1", "2"]),
    "--modules": st.sampled_from(HOSTILE + ["t45", "t45,t30", "t45,,t30", "nope"]),
    "--csv-header": st.sampled_from(["auto", "yes", "no", "maybe"]),
    "--model": st.sampled_from(["", "missing.zip"]),
}
SHOW_OPTIONS = {
    "--cells": st.sampled_from(
        HOSTILE
        + ["[[0,0]]", "[[0,0],[1,0]]", "[[0,0],[2,0]]", "[[0,0],[0,0]]", "[[1e400,0]]"]
        + ["[[0.5,0]]", "[[true,0]]", '[["a",0]]', "[[1e300,0]]", "{}", "[" * 5000, "[[0]]"]
    ),
    "--task": st.sampled_from([SCREWDRIVER, "missing.json", ""]),
    "--n-max": _values(["1", "2", "3"]),
    "--modules": st.sampled_from(HOSTILE + ["t45", "t45,t30"]),
    "--csv-header": st.sampled_from(["auto", "yes", "maybe"]),
}
GENERATE_OPTIONS = {
    "--seed": _values(["0", "3"]),
    "--task-kind": st.sampled_from(["total", "external", "bogus"]),
    "--f-max": _values(["2.5", "1e-3"]),
}
NUMERIC = {"--n-max", "--seed", "--workers", "--f-max"}


def _nonsense(option: str, value: str) -> bool:
    """True for a value that no numeric option may accept silently."""
    if option not in NUMERIC:
        return False
    bad = {"-1", "nan", "inf", "-inf", "1e400", "", "ü", "1_0", "0x10"}
    if option != "--f-max":
        bad |= {"1.5", str(10**30)} | ({"0"} if option != "--seed" else set())
    else:
        bad |= {"0"}
    return value in bad


@st.composite
def options(draw, table: dict) -> list[tuple[str, str]]:
    names = draw(st.lists(st.sampled_from(sorted(table)), unique=True, max_size=len(table)))
    return [(name, draw(table[name])) for name in names]


def _argv(pairs: list[tuple[str, str]]) -> list[str]:
    """Option pairs as argv; ``--opt=value`` when the value starts with '-' (argparse would read
    ``-inf`` as an option)."""
    out: list[str] = []
    for k, v in pairs:
        out += [f"{k}={v}"] if v.startswith("-") else [k, v]
    return out


def check_options(capsys, argv: list[str], pairs: list[tuple[str, str]]) -> int:
    code, out, err = run_main(capsys, argv)
    assert_clean_exit(code, err)
    if any(_nonsense(k, v) for k, v in pairs):
        assert code == 2, (argv, out)
    return code


@FUZZ
@given(pairs=options(SOLVE_OPTIONS))
def test_solve_options(capsys, pairs):
    check_options(capsys, ["solve", "--task", SCREWDRIVER, "--quiet", *_argv(pairs)], pairs)


@FUZZ
@given(pairs=options(SHOW_OPTIONS))
def test_show_options(tmp_path, capsys, monkeypatch, pairs):
    monkeypatch.chdir(tmp_path)
    argv = ["show", "--out", str(tmp_path / "s.png"), "--force", *_argv(pairs)]
    check_options(capsys, argv, pairs)


@FUZZ
@given(
    pairs=options(GENERATE_OPTIONS),
    kind=st.sampled_from(["paper", "planted", "screwdriver", "bogus", ""]),
    name=st.sampled_from(["t.json", "t.csv", "t.npy", "t.txt", "t", "sub/t.json", "ü.json"]),
)
def test_task_generate_options(tmp_path, capsys, pairs, kind, name):
    out = tmp_path / name
    argv = ["task", "generate", "--kind", kind, "--out", str(out), "--force", *_argv(pairs)]
    if check_options(capsys, argv, pairs) == 0:
        task = TaskRequirement.load(out)  # what was written reads back
        assert np.isfinite(task.wrenches).all()


BENCH_COUNTS = {
    "paper": ["--seeds"],
    "oracle": ["--structures", "--wrenches", "--repeats", "--seed"],
    "search": ["--tasks", "--reference-structures", "--seed"],
    "env": ["--steps", "--n-max", "--sizes", "--seed"],
    "scaling": ["--n-max", "--seed"],
    "level_bounds": ["--n-max"],
    "heterogeneous": ["--tasks", "--seed", "--n-max"],
    "agents": ["--n-max", "--seed", "--limit", "--workers"],
    "distributed": ["--tasks", "--n-max", "--search-n-max", "--seed"],
}


@FUZZ
@given(
    what=st.sampled_from(sorted(BENCH_COUNTS)),
    data=st.data(),
    value=st.sampled_from([v for v in HOSTILE if v != "0"] + ["0"]),
)
def test_bench_rejects_hostile_counts_before_work(tmp_path, capsys, monkeypatch, what, data, value):
    """Every benchmark (and ``modquad score``) refuses a hostile count or seed while parsing:
    exit 2, nothing written."""
    option = data.draw(st.sampled_from(BENCH_COUNTS[what]))
    assume(not (value == "0" and option == "--seed"))  # seed 0 is a fine seed
    monkeypatch.chdir(tmp_path)
    code, _, err = run_bench(capsys, [what, f"{option}={value}", "--out", str(tmp_path)])
    assert code == 2, err
    assert "Traceback" not in err and option in err.strip().splitlines()[-1]
    assert not list(tmp_path.iterdir())


def test_bench_out_must_be_a_folder(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    for what in sorted(BENCH_COUNTS):
        code, _, err = run_bench(capsys, [what, "--out", str(blocker)])
        assert code == 2 and "not a folder" in err, (what, err)


# ------------------------------------------------------------------ (c) API arguments
ANY = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**30), 10**30),
    st.sampled_from(["2", "", True, False, None, [1.0], np.float64(0.5), np.int64(3), 1 + 2j]),
)


@FUZZ
@given(eta=ANY)
def test_t_module_eta(eta):
    try:
        m = mq.TModule(eta=eta)
    except ValueError as exc:
        assert "eta" in str(exc)
        return
    assert isinstance(eta, (int, float, np.floating, np.integer)) and not isinstance(eta, bool)
    assert abs(float(eta)) <= math.pi / 2
    assert np.isfinite(m.directions).all() and (m.directions[:, 2] >= -1e-12).all()


CELL_VALUE = st.one_of(
    st.integers(-3, 3),
    st.integers(-(10**30), 10**30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([True, None, "0", np.int64(1), np.float64(1.0), np.int64(2**62)]),
)


@FUZZ
@given(cells=st.one_of(st.lists(st.tuples(CELL_VALUE, CELL_VALUE), max_size=4), ANY))
def test_structure_cells(cells):
    try:
        s = mq.Structure(cells)
    except ValueError as exc:
        assert "cell" in str(exc)
        return
    assert all(isinstance(x, int) and isinstance(y, int) for x, y in s.cells)
    assert np.isfinite(s.configuration_matrix()).all()


A_PAIR = mq.Structure([(0, 0), (1, 0)]).configuration_matrix()
W_UP = np.array([[0.0, 0.0, 3.0, 0.0, 0.0, 0.0]])


def _valid_f_max(f) -> bool:
    return (
        isinstance(f, (int, float, np.floating, np.integer))
        and not isinstance(f, (bool, np.bool_))
        and math.isfinite(f)
        and f > 0
    )


@FUZZ
@given(f_max=ANY, which=st.sampled_from(["feasible", "margin", "exhaustive_search"]))
def test_f_max_argument(f_max, which):
    fn = {
        "feasible": lambda: mq.feasible(A_PAIR, W_UP, f_max=f_max),
        "margin": lambda: mq.margin(A_PAIR, W_UP, f_max=f_max),
        "exhaustive_search": lambda: mq.exhaustive_search(W_UP, n_max=2, f_max=f_max),
    }[which]
    if f_max is None and which == "exhaustive_search":  # None: the task's own f_max (1 here)
        assert fn().n_modules == mq.exhaustive_search(W_UP, n_max=2, f_max=1.0).n_modules
        return
    try:
        fn()
    except ValueError as exc:
        assert "f_max" in str(exc)
        # refused by name: invalid, beyond every door's 1e-300..1e12, or absurd for a search
        # (so small that the task's 3 N is more than 1e100 f_max)
        assert not _valid_f_max(f_max) or f_max * 1e100 < 3 or f_max > 1e12
        return
    assert _valid_f_max(f_max)


ENV_KWARGS = {
    "n_max": st.one_of(ANY, st.sampled_from([2, 7, 16, 17, 10**9])),
    "f_max": ANY,
    "max_steps": st.one_of(ANY, st.sampled_from([10, 64, 65])),
    "n_directions": st.one_of(ANY, st.sampled_from([12, 48, 4096, 4097, 10**9])),
    "oracle_method": st.sampled_from(["auto", "daqp", "bogus", "", None, 3]),
    "render_size": st.one_of(
        ANY, st.sampled_from([(64, 64), (0, 0), (-1, 5), (10**6, 10**6), "ab", (1.5, 2)])
    ),
    "reward_weights": st.sampled_from([None, {}, {"bogus": 1}, {"w_success": math.nan}, "x"]),
    "invalid_action": st.sampled_from(["penalise", "terminate", "bogus", None]),
    "lookahead": st.one_of(ANY, st.booleans()),
}


@settings(FUZZ, max_examples=int(DEEP) if DEEP else 20)
@given(key=st.sampled_from(sorted(ENV_KWARGS)), data=st.data())
def test_env_kwargs(key, data):
    import gymnasium as gym

    value = data.draw(ENV_KWARGS[key])
    try:
        env = gym.make("ModQuadAssembly-v0", **{key: value})
    except (ValueError, TypeError) as exc:
        message = str(exc)
        assert key in message or key.replace("_", " ").rstrip("s") in message, (key, exc)
        return
    try:
        env.reset(seed=0)
    finally:
        env.close()


# ------------------------------------------------------------------ (3) oracle scale invariance
STRUCTURES = {
    "single (rank 4)": [(0, 0)],
    "pair (rank 5)": [(0, 0), (1, 0)],
    "L (rank 6)": [(0, 0), (1, 0), (0, 1)],
    "T4 (rank 6)": [(0, 0), (1, 0), (2, 0), (1, 1)],
}


def _wrenches(A: np.ndarray, seed: int, t: int = 6) -> np.ndarray:
    """Wrenches around the zonotope: images of random thrusts pushed in and out from the hover
    wrench, and a few off range(A) for rank-deficient A."""
    rng = np.random.default_rng(seed)
    c = A.sum(axis=1) / 2
    inside = (A @ rng.uniform(0, 1, (t, A.shape[1])).T).T
    pushed = c + (inside - c) * rng.uniform(0.3, 2.5, (t, 1))
    return np.vstack([pushed, rng.normal(scale=2.0, size=(2, 6))])


def _gamma_linprog(A: np.ndarray, w: np.ndarray) -> float:
    """Reference gamma straight from A, independent of the oracle's coordinates:
    min t s.t. A u = w, |2 u_j - 1| <= t (HiGHS)."""
    from scipy.optimize import linprog

    m = A.shape[1]
    cost = np.r_[np.zeros(m), 1.0]
    two = 2 * np.eye(m)
    col = -np.ones((m, 1))
    A_ub = np.vstack([np.hstack([two, col]), np.hstack([-two, col])])
    b_ub = np.r_[np.ones(m), -np.ones(m)]
    res = linprog(
        cost,
        A_ub=A_ub,
        b_ub=b_ub,
        A_eq=np.hstack([A, np.zeros((6, 1))]),
        b_eq=w,
        bounds=(None, None),
        method="highs",
    )
    return float(res.fun) if res.status == 0 else math.inf


@settings(FUZZ, max_examples=int(DEEP) if DEEP else 25)
@given(
    name=st.sampled_from(sorted(STRUCTURES)),
    seed=st.integers(0, 2**16),
    log_scale=st.floats(-9, 12),
    method=st.sampled_from(["auto", "daqp", "scipy", "hrep"]),
)
def test_oracle_is_scale_invariant(name, seed, log_scale, method):
    """feasible/margin give the same answers for (s W, s f_max) as for (W, 1), s in 1e-9..1e12,
    and agree with an independent LP on the normalised problem."""
    A = mq.Structure(STRUCTURES[name]).configuration_matrix()
    W = _wrenches(A, seed)
    s = 10.0**log_scale
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow or invalid-value warnings on the way
        d1, m1 = mq.feasible(A, W, method=method), mq.margin(A, W, method=method)
        ds = mq.feasible(A, W * s, f_max=s, method=method)
        ms = mq.margin(A, W * s, f_max=s, method=method)
    gamma = np.array([_gamma_linprog(A, w) for w in W])
    clear = np.abs(gamma - (1 + TOL)) > 10 * BAND
    np.testing.assert_array_equal(ds[clear], d1[clear])
    np.testing.assert_array_equal(d1[clear], (gamma <= 1 + TOL)[clear])
    np.testing.assert_array_equal(ms >= 0, ds)
    finite = np.isfinite(m1)
    np.testing.assert_array_equal(finite, np.isfinite(ms))
    np.testing.assert_allclose(ms[finite], m1[finite], atol=1e-7)
    on_range = np.isfinite(gamma) & finite
    np.testing.assert_allclose(m1[on_range & clear], 1 - gamma[on_range & clear], atol=1e-6)


@settings(FUZZ, max_examples=int(DEEP) if DEEP else 25)
@given(
    name=st.sampled_from(sorted(STRUCTURES)),
    exponent=st.integers(20, 307),
    signs=st.lists(st.sampled_from([-1.0, 0.0, 1.0]), min_size=6, max_size=6),
    method=st.sampled_from(["auto", "daqp", "scipy", "hrep"]),
)
def test_huge_wrenches_are_decided_without_overflow(name, exponent, signs, method):
    """Components like 1e200: infeasible, a margin far below zero (or -inf beyond the float
    range), and never an overflow warning or an LP failure."""
    assume(any(signs))
    A = mq.Structure(STRUCTURES[name]).configuration_matrix()
    w = np.array(signs) * 10.0**exponent
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ok = mq.feasible(A, w, method=method)
        m = mq.margin(A, w, method=method)
        ratio = mq.lambda_ratio(A, w)
    assert not ok.any()
    assert m[0] < -1e10 and ratio[0] < 1
    # a huge f_max is refused by name (every door's range ends at 1e12 N); in units of the
    # largest, the same direction is an ordinary wrench, decided as the small one
    small = w / 10.0**exponent
    with pytest.raises(ValueError, match=r"^f_max = .* is outside 1e-300\.\.1e12 "):
        mq.feasible(A, w, f_max=10.0**exponent, method=method)
    np.testing.assert_array_equal(
        mq.feasible(A, small * 1e12, f_max=1e12, method=method), mq.feasible(A, small)
    )
