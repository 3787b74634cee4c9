"""A required margin after the failure (fault_margin=mu) and two rotor failures (fault="rotor2"),
checked against HiGHS on every failed matrix, through the bounds, the searches, the env and the
command line (issue 47)."""

import itertools

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.cli import main
from modquad_gym.oracle.faults import failure_sets, margin_for_delay
from modquad_gym.search.bounds import force_lower_bound
from modquad_gym.tasks import PaperTasks, load_task

SQUARE = [(0, 0), (1, 0), (0, 1), (1, 1)]
LINE = [(0, 0), (1, 0), (2, 0)]  # rank 5


def wrenches_of(structure, rng, t=40, lo=0.15, hi=0.85):
    """Wrenches inside the intact zonotope, some close to what a failure leaves."""
    A = structure.configuration_matrix()
    U = rng.uniform(lo, hi, size=(t, A.shape[1]))
    U[: t // 4, rng.integers(A.shape[1], size=t // 4)] = 0.0  # some lean on a dead rotor
    return U @ A.T


def lp_after_every_failure(A, W, fault, mu=0.0):
    """The reference: HiGHS margin (1 - gamma) on each failed matrix, the worst per wrench."""
    worst = np.full(len(W), np.inf)
    for S in failure_sets(A.shape[1], fault):
        keep = np.ones(A.shape[1], dtype=bool)
        keep[S] = False
        worst = np.minimum(worst, mq.margin(A[:, keep], W, method="scipy"))
    return worst


@pytest.mark.parametrize("cells", [SQUARE, LINE, [(0, 0)]])
def test_rotor2_agrees_with_highs_on_every_failed_matrix(cells):
    s = mq.Structure(cells)
    A = s.configuration_matrix()
    rng = np.random.default_rng(len(cells))
    W = wrenches_of(s, rng, t=12)
    ref = lp_after_every_failure(A, W, "rotor2")
    clear = np.abs(ref) > 1e-6  # outside the LPs' shared round-off band
    for method in ("auto", "daqp"):
        ok = mq.tolerates(s, W, fault="rotor2", method=method)
        assert (ok[clear] == (ref[clear] >= 0)).all()
    if cells == SQUARE:  # both answers occur
        assert ok.any() and not ok.all()
    assert len(failure_sets(A.shape[1], "rotor2")) == A.shape[1] * (A.shape[1] - 1) // 2


@pytest.mark.parametrize("fault", ["rotor", "module", "rotor2"])
@pytest.mark.parametrize("mu", [0.05, 0.2])
def test_a_required_margin_is_the_worst_margin_after_the_failure(fault, mu):
    s = mq.Structure(SQUARE)
    rng = np.random.default_rng(7)
    W = wrenches_of(s, rng, t=8 if fault == "rotor2" else 16, lo=0.3, hi=0.7)
    A = s.configuration_matrix()
    ref = lp_after_every_failure(A, W, fault) if fault != "module" else None
    if ref is None:
        ref = mq.fault_margin(s, W, fault="module", method="scipy")
    clear = np.abs(ref - mu) > 1e-6
    for method in ("auto", "scipy"):
        ok = mq.tolerates(s, W, fault=fault, fault_margin=mu, method=method)
        assert (ok[clear] == (ref[clear] >= mu)).all()
    # a margin only removes wrenches
    assert not (ok & ~mq.tolerates(s, W, fault=fault)).any()


def test_the_bounds_stay_below_the_certified_minima():
    tasks = [PaperTasks(n_wrenches=10)(np.random.default_rng(3)), load_task("example:screwdriver")]
    for task in tasks:
        plain = mq.exhaustive_search(task, n_max=8, fault="rotor")
        two = mq.exhaustive_search(task, n_max=8, fault="rotor2")
        margin = mq.exhaustive_search(task, n_max=8, fault="rotor", fault_margin=0.05)
        for r in (plain, two, margin):
            assert r.n_modules is not None and r.certified
        bound = force_lower_bound(task.wrenches, mq.TModule(), task.f_max, "rotor2")
        assert bound <= two.n_modules
        assert plain.n_modules <= two.n_modules and plain.n_modules <= margin.n_modules
        # the margin=0 bounds stay valid with a margin: they never exceed its optimum
        assert force_lower_bound(task.wrenches, mq.TModule(), task.f_max, "rotor") <= (
            margin.n_modules
        )
        W = task.rotor_wrenches(margin.structure)
        assert mq.fault_margin(margin.structure, W, task.f_max, fault="rotor").min() >= 0.05 - 1e-6
        if task.name == "screwdriver":  # HiGHS on every failed matrix of the answer
            A = two.structure.configuration_matrix()
            W = task.rotor_wrenches(two.structure)
            assert (lp_after_every_failure(A, W, "rotor2") > -1e-6).all()


def test_the_problem_carries_the_margin_and_refuses_it_alone():
    task = load_task("example:screwdriver")
    p = mq.SearchProblem(task, n_max=6, fault="rotor", fault_margin=0.02)
    assert p.fault_margin == 0.02 and p.replace(fault=None).fault_margin == 0.0
    assert mq.anytime_search(p, time_limit=5).to_dict()["fault_margin"] == 0.02
    with pytest.raises(ValueError, match="applies with a fault"):
        mq.SearchProblem(task, fault_margin=0.1)
    with pytest.raises(ValueError, match=r"fault_margin must lie in \[0, 1\)"):
        mq.SearchProblem(task, fault="rotor", fault_margin=1.0)
    with pytest.raises(ValueError, match="fault_margin"):
        mq.anytime_search(p, fault_margin=0.1)  # beside a problem: refused
    with pytest.raises(ValueError, match="cannot honour"):
        mq.make_solver("milp", fault="rotor2", fault_margin=0.1)


def test_the_env_takes_rotor2_and_a_margin():
    env = gym.make("ModQuadAssembly-v0", task="example:screwdriver", fault="rotor2",
                   fault_margin=0.05, n_max=6)  # fmt: skip
    obs, info = env.reset(seed=0)
    for _ in range(6):
        mask = env.unwrapped.action_masks()
        obs, reward, terminated, truncated, info = env.step(int(np.flatnonzero(mask)[0]))
        if terminated or truncated:
            break
    s = env.unwrapped.structure if hasattr(env.unwrapped, "structure") else None
    if info["is_success"] and s is not None:
        task = load_task("example:screwdriver")
        W = task.rotor_wrenches(s)
        assert mq.tolerates(s, W, fault="rotor2", fault_margin=0.05).all()
    with pytest.raises(ValueError, match="fault_margin"):
        gym.make("ModQuadAssembly-v0", fault="rotor", fault_margin=-0.1)


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["--fault-margin", "0.1"], "--fault-margin applies with --fault"),
        (["--fault", "rotor", "--fault-margin", "1.5"], r"must lie in \[0, 1\)"),
        (["--fault", "rotor", "--detection-delay", "0.2"], "calibrated range"),
        (["--fault", "rotor", "--detection-delay", "0.02", "--fault-margin", "0.1"], "not both"),
    ],
)
def test_the_command_line_refuses_bad_margins(argv, match, capsys):
    assert main(["solve", "--task", "example:screwdriver", *argv]) == 2
    assert match.replace("\\", "") in capsys.readouterr().err.replace("\\", "")


def test_the_delay_picks_the_margin(capsys):
    import json

    argv = ["solve", "--task", "example:screwdriver", "--fault", "rotor", "--json"]
    assert main([*argv, "--detection-delay", "0.02"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["fault_margin"] == pytest.approx(margin_for_delay(0.02))
    assert record["worst_fault_margin"] >= margin_for_delay(0.02) - 1e-6


def test_a_two_rotor_failure_is_flown():
    from modquad_gym.sim.fault_flight import fly_with_failure

    task = load_task("example:screwdriver")
    s = mq.exhaustive_search(task, n_max=7, fault="rotor2").structure
    f = fly_with_failure(s, task, "rotor2", seconds=1.0, detection_delay_s=0.0)
    assert len(f.failure.columns) == 2 and f.worst.tolerates
    assert f.max_position_error_m < 0.05
    assert list(itertools.islice(f.failure.columns, 2)) == list(f.worst.columns)


@pytest.mark.parametrize("value", ["0.1", True, None])
def test_a_margin_that_is_not_a_number_is_refused_by_every_door(value):
    """A string or a bool is no margin (``float()`` used to take "0.1" and True as 0.1 and 1)."""
    from modquad_gym import make_solver
    from modquad_gym.oracle.failures import check_fault_margin

    with pytest.raises(ValueError, match="fault_margin must be a number in"):
        check_fault_margin(value)
    if value is not None:  # None: the margin not given, for the doors
        with pytest.raises(ValueError, match="fault_margin must be a number in"):
            make_solver("greedy", fault="rotor", fault_margin=value)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (("0.02",), "detection delay must be a number of seconds, got '0.02'"),
        ((False,), "detection delay must be a number of seconds, got False"),
        ((True,), "detection delay must be a number of seconds, got True"),
        (
            (0.02, ["rotor"]),
            "fault must be one of 'rotor', 'module', 'rotor2', 'rotor+module', got ['rotor']",
        ),
    ],
)
def test_margin_for_delay_refuses_what_the_fault_door_refuses(args, match):
    """A string or a bool is no delay (fly_with_failure and check_fault_margin refuse them);
    a fault that is no kind's name is named, not an unhashable-type TypeError."""
    import re

    with pytest.raises(ValueError, match=re.escape(match)):
        margin_for_delay(*args)


@pytest.mark.parametrize("command", ["solve", "validate"])
@pytest.mark.parametrize("delay", ["2", "0.06", "-0.01"])
def test_the_detection_delay_has_one_range_and_its_option_named(command, delay, tmp_path,
                                                                 capsys):  # fmt: skip
    out = ["--out", str(tmp_path / "v")] if command == "validate" else []
    argv = [command, "--task", "example:screwdriver", "--fault", "rotor", *out]
    assert main([*argv, "--detection-delay", delay]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith(
        f"--detection-delay must lie in [0, 0.05] s (the rule's calibrated range), got {delay}"
    ), err
    assert not (tmp_path / "v").exists()


@pytest.mark.parametrize("fault", ["rotor", "module", "rotor2", "rotor+module"])
def test_the_smallest_margin_failure_is_the_same_for_the_flight_and_its_cases(fault):
    """``worst_failure`` and the smallest-margin one of ``failure_cases`` (one shared set-up of
    the failures and the margin method) name the same failure, margin, wrench and verdict."""
    from modquad_gym.sim.fault_flight import failure_cases, worst_failure

    task = mq.TaskRequirement.load("examples/screwdriver.json")
    s = mq.Structure([(0, 0), (0, 1), (1, 0), (1, 1), (2, 0)])
    W = task.rotor_wrenches(s)
    worst = worst_failure(s, W, task.f_max, fault)
    cases = failure_cases(s, W, task.f_max, fault)
    low = min(cases, key=lambda c: c.margin)
    assert (low.index, low.row, low.tolerates) == (worst.index, worst.row, worst.tolerates)
    assert list(low.columns) == list(worst.columns)
    assert abs(low.margin - worst.margin) < 1e-6
