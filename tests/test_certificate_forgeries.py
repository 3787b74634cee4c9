"""Certificates forged to prove something false are refused (the proofs review): a separating
direction so small that its tolerance underflowed, answer cells so far out that their float
positions are hundreds of cells apart, an f_max so small that the answer's residual tolerance
underflowed. The checker works in units of f_max with its directions scaled, so the verdict
does not depend on the units a certificate is written in; a module type must be physical."""

from __future__ import annotations

import copy
import gzip
import itertools
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import linprog
from test_certificate_inputs import doors

import modquad_gym as mq
from modquad_gym import proofcheck as pc
from modquad_gym import proofcheck_format as pcf
from modquad_gym import proofcheck_shapes as pcs
from modquad_gym.search import certificates
from modquad_gym.search.problem import SearchProblem


def certify(wrenches: list, n_max: int = 5) -> dict:
    problem = SearchProblem.build(np.array(wrenches), n_max=n_max)
    return certificates.make(mq.exhaustive_search.solve(problem), problem, bounds=False)


@pytest.fixture(scope="module")
def docs_example() -> dict:
    """docs/certificates.md's task: the minimum is 2 modules."""
    cert = certify([[0, 0, 5.0, 0, 0, 0], [0.4, 0, 4.0, 0, 0, 0.05]])
    assert pc.check(copy.deepcopy(cert)).startswith("valid: the minimum is 2 modules")
    return cert


def with_answer(cert: dict, cells: list, f_max: float | None = None) -> dict:
    """``cert`` claiming the structure of one-type ``cells`` (floats as the checker used to
    place them), with thrusts in [0, f_max] that reach each wrench there (an LP)."""
    c = copy.deepcopy(cert)
    c.pop("n_max", None)
    f_max = c["f_max"] if f_max is None else f_max
    T, task = pc.Types(c["types"]), pc.fmt.task_model(c["task"])
    a, M, j = T.columns(np.array([cells], dtype=float), np.zeros((1, len(cells)), int))
    t = len(task[0])
    W = pc.wrenches(task, np.arange(t), np.repeat(M, t), np.repeat(j, t, axis=0))
    U = []
    for w in W:
        lp = linprog(np.zeros(a.shape[1]), A_eq=a[0].T, b_eq=w, bounds=(0, f_max))
        assert lp.status == 0, lp.message  # the forgery works where the structure is misplaced
        U.append(lp.x.tolist())
    c["minimum"] = len(cells)
    c["answer"] = {"cells": cells, "types": [0] * len(cells), "allocations": [U]}
    c["levels"] = [e for e in c["levels"] if e["n"] < len(cells)]
    return c


@pytest.mark.parametrize("size", [1e-323, 1e-170])
def test_a_tiny_direction_proves_nothing(docs_example, size):
    """Level 2 'proved' by one tiny direction for every structure: the tolerance
    1e-11 |d| scale was 0 (|d| underflowed), and round-off decided the test."""
    forged = with_answer(docs_example, [[0, 0], [1, 0], [2, 0]])
    forged["directions"].append([0.0, 0.0, size, 0.0, 0.0, 0.0])
    total = pc.count(2, 1)
    k = len(forged["directions"]) - 1
    forged["levels"].append({"n": 2, "direction": [k] * total, "wrench": [0] * total})
    with pytest.raises(pc.ProofError, match="level 2: structure 0 .* does not separate"):
        pc.check(forged)


def test_answer_cells_are_placed_as_integers():
    """A 2-module answer at cells beyond 2^53 was placed from float coordinates hundreds of
    cells apart: its lever arms reached a torque that no 5 modules reach."""
    torque = certify([[0, 0, 2.5, 3.0, 0, 0]])
    assert torque["minimum"] is None and torque["n_max"] == 5
    far = -(2**60 + 128)
    forged = with_answer(torque, [[0, far], [0, far - 1]])
    with pytest.raises(
        pc.ProofError, match="answer: allocation: wrench 0: component 3 of A u differs"
    ):
        pc.check(forged)


def test_a_translated_answer_is_the_same_answer(docs_example):
    moved = copy.deepcopy(docs_example)
    moved["answer"]["cells"] = [[x + 2**62, y - 2**62] for x, y in moved["answer"]["cells"]]
    assert pc.check(moved) == pc.check(copy.deepcopy(docs_example))


def test_a_tiny_f_max_proves_nothing(docs_example):
    """f_max = 5e-324: thrusts rounded to whole multiples of it and a residual tolerance of 0
    let two modules 'reach' 8 f_max upwards (they reach 5.66 f_max)."""
    f = 5e-324
    forged = with_answer(docs_example, [[0, 0], [1, 0]])
    forged["f_max"] = f
    forged["task"] = {"name": "tiny", "kind": "total", "base": [[0, 0, 8 * f, 0, 0, 0]],
                      "per_mass": None, "per_inertia": None}  # fmt: skip
    forged["answer"]["allocations"] = [[[f] * 8]]
    forged["directions"] = [[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]
    forged["levels"] = [{"n": 1, "direction": [0], "wrench": [0]}]
    with pytest.raises(pc.ProofError, match="wrench 0: component 2 of A u differs from the wrench"):
        pc.check(forged)


@pytest.mark.parametrize("unit", [1e-200, 1e-3, 1e150])
def test_the_units_change_no_verdict(docs_example, unit):
    """The same certificate in other units of force (f_max, wrenches, thrusts) and with its
    directions scaled is the same proof."""
    c = copy.deepcopy(docs_example)
    c["f_max"] *= unit
    c["task"]["base"] = (np.array(c["task"]["base"]) * unit).tolist()
    c["task"]["per_mass"] = (np.array(c["task"]["per_mass"]) * unit).tolist()
    c["answer"]["allocations"] = (np.array(c["answer"]["allocations"]) * unit).tolist()
    c["directions"] = (np.array(c["directions"]) * unit).tolist()
    assert pc.check(c) == pc.check(copy.deepcopy(docs_example))


def test_huge_directions_are_directions(docs_example, tmp_path, capsys):
    """A direction of 1e300 is scaled like any other (it once overflowed into numpy's warning
    before a verdict of 'does not separate'): the proof is the same, in one line."""
    c = copy.deepcopy(docs_example)
    c["directions"] = (np.array(c["directions"]) * 1e300).tolist()
    path = tmp_path / "huge.json"
    path.write_text(json.dumps(c))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning fails the test
        verdicts = doors(path, capsys)
    for code, out, err in verdicts:
        assert (code, out, err) == (0, pc.check(copy.deepcopy(docs_example)) + "\n", "")


def test_an_overflowing_task_is_refused_in_one_line(docs_example):
    c = copy.deepcopy(docs_example)
    c["f_max"] = 1e-308  # 5 N over it is beyond the largest double
    with pytest.raises(pc.CertificateFormatError, match=r"task: its wrench model over f_max"):
        pc.check(c)


def type_changed(field: str, value) -> dict:
    return {"types": {0: {field: value}}}


@pytest.mark.parametrize(
    "field, value, words",
    [
        ("mass", -1.0, "types[0].mass: must be positive, not -1.0"),
        ("side", 0.0, "types[0].side: must be positive"),
        ("spins", [7.0, -7.0, 7.0, -7.0], "types[0].spins: must each be 1 or -1"),
        ("side", 11.0, "types[0].side: must be at most 10 m"),
        ("c_tau", -1e10, "types[0].c_tau: must be at most 10 m in magnitude"),
        ("positions", [[0, 0, 1e5]] * 4, "types[0].positions: must be at most 10 m in each axis"),
        (
            "inertia",
            [[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]],
            "types[0].inertia: must be symmetric",
        ),
        ("inertia", [[-1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]], "positive semi-definite"),
    ],
)
def test_a_type_that_is_no_module_is_refused(docs_example, field, value, words):
    c = copy.deepcopy(docs_example)
    c["types"][0][field] = value
    with pytest.raises(
        pc.CertificateFormatError, match=words.replace("[", r"\[").replace(".", r"\.")
    ):
        pc.check(c)


def test_a_second_type_of_another_side_is_refused(docs_example):
    c = copy.deepcopy(docs_example)
    c["types"].append(dict(c["types"][0], side=c["types"][0]["side"] * 2))
    with pytest.raises(pc.CertificateFormatError, match=r"types\[1\]\.side: must be the first"):
        pc.check(c)


@pytest.mark.parametrize(
    "kind, terms, words",
    [
        ("banana", {}, 'task.kind: must be "total", "external", "dynamic", not "banana"'),
        ("total", {"per_mass": [[0, 0, -9.81, 0, 0, 0]] * 2}, "task.per_mass: must be null"),
        ("external", {"per_inertia": [np.eye(6).tolist()] * 2}, "task.per_inertia: must be null"),
    ],
)
def test_a_task_is_what_its_kind_says(docs_example, kind, terms, words):
    c = copy.deepcopy(docs_example)
    c["task"].update(kind=kind, **terms)
    with pytest.raises(pc.CertificateFormatError, match=words):
        pc.check(c)


FORGED = Path(__file__).parent / "data" / "forged_certificates"


@pytest.mark.parametrize(
    "name, words",
    [
        # a hover one module exerts, as base + M per_mass with terms of 2^62 that cancel: the
        # round-off of d . base (25) passed a bound whose tolerance scaled with the result
        ("bound_cancel", "level 1: bound: direction 0 does not exceed the level's support"),
        # M = 0.3 + 0.3 + 0.3 rounds, times a per_mass of 2^52: the computed wrench moved by
        # 0.25 f_max and level 3 was 'proved' where a straight line reaches the exact wrench
        ("separation_cancel", "level 3: structure 0 .* does not separate wrench 0"),
        # the same round-off let the answer meet the computed wrench, not the task's
        ("answer_cancel", "wrench 0: component 0 of A u differs from the wrench"),
        # c_tau 1e10: a reachable yaw torque of 1.4e10 bought 14 f_max of error in the lift
        # (one tolerance for all six components): one module 'lifted' 15 f_max; such a drag
        # ratio is no module's now, and each component has its own tolerance (next test)
        ("torque_buys_lift", r"types\[0\]\.c_tau: must be at most 10 m in magnitude"),
        # (third review) Jxz of +-0.1 summed over six modules is 2.8e-17, not 0: times a
        # per_inertia of 2.16e17 the computed wrench was a hover where the exact one pushes down
        ("inertia_cancel", "wrench 0: component 2 of A u differs from the wrench"),
        # every thrust at -1e-6 f_max (the old tolerance, twice the oracle's) pushed down
        ("negative_thrust", "wrench 0: a thrust outside"),
        # (fourth review) one flat module at thrust 1 + 5.005e-7: within the checker's old
        # band, beyond the oracle's (5e-7), which certifies 2 modules
        ("beyond_the_band", "wrench 0: a thrust outside"),
    ],
)
def test_round_off_of_the_task_model_proves_nothing(name, words):
    """Forgeries of the second proofs review (``tests/data/forged_certificates``): the
    tolerances scale with the magnitudes of the task model's terms, not the computed wrench."""
    with pytest.raises((pc.ProofError, pc.CertificateFormatError), match=words):
        pc.check(pc.load(str(FORGED / f"{name}.json")))


def test_each_component_of_the_answer_has_its_own_tolerance():
    """A large yaw torque widens the yaw component's allowed residual, not the lift's."""
    A = np.array([[0.0, 0, 1, 1], [0, 0, 0, 0], [1, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0],
                  [10, -10, 0, 0]])  # fmt: skip
    W = np.array([[0, 0, 2.0, 0, 0, 0], [0, 0, 2.0, 0, 0, 1e6]])
    allowed = pc.residual_allowed(A, W, np.abs(W), 1.0)
    assert allowed[0, 2] == allowed[1, 2] < 1e-10 and allowed[1, 5] > 1e-6


def test_an_external_task_adds_the_weight(docs_example):
    c = copy.deepcopy(docs_example)
    weight = 9.81 * sum(c["types"][k]["mass"] for k in c["answer"]["types"])
    c["task"]["kind"] = "external"
    c["task"]["base"] = [[x, y, z - weight, *rest] for x, y, z, *rest in c["task"]["base"]]
    c["task"]["per_mass"] = [[0, 0, 9.81, 0, 0, 0], [0, 0, 9.81, 0, 0, 0]]
    assert pc.check(copy.deepcopy(c)).startswith("valid")  # any g > 0, one for every wrench
    c["task"]["per_mass"][1] = [1.0, 0, 9.81, 0, 0, 0]
    with pytest.raises(pc.CertificateFormatError, match="task.per_mass: an external task's"):
        pc.check(c)


def impossible(levels: int) -> dict:
    """A true certificate that no structure of up to ``levels`` T-modules pushes down (f_z =
    -1 f_max), each level by a bound."""
    from modquad_gym.geometry.module import TModule

    return {"format": pc.FORMAT, "version": pc.VERSION, "f_max": 1.0, "fault": None,
            "types": [certificates.type_dict(TModule())], "n_max": levels, "minimum": None,
            "task": {"name": "down", "kind": "total", "base": [[0, 0, -1.0, 0, 0, 0]],
                     "per_mass": None, "per_inertia": None},
            "directions": [[0, 0, -1.0, 0, 0, 0]],
            "levels": [{"n": n, "bound": {"direction": 0, "wrench": 0}}
                       for n in range(1, levels + 1)]}  # fmt: skip


def test_the_checker_does_only_the_work_the_file_pays_for():
    """(third review) A 1 kB file made the checker build a set of every level up to n_max
    (2^63: all memory), or enumerate the 7.2 million shapes of 14 cells before it compared
    a level's entry count; the count is read off OEIS A001168 now."""
    assert pc.check(impossible(13)).startswith("valid: no structure of up to 13 modules")
    huge = impossible(3) | {"n_max": 2**63 - 1}
    with pytest.raises(pc.ProofError, match="level 4: no proof"):
        pc.check(huge)
    empty = impossible(13) | {"n_max": 14}
    empty["levels"].append({"n": 14, "direction": [], "wrench": []})
    pcs.shape_keys.cache_clear()
    with pytest.raises(
        pc.ProofError, match="level 14: direction: has 0 entries, there are 7204874"
    ):
        pc.check(empty)
    assert pcs.shape_keys.cache_info().currsize == 0  # nothing enumerated


def test_work_is_bounded_by_rotors_and_bytes(tmp_path, monkeypatch):
    """A type of 256 rotors asked for 960 MiB per block; blocks are sized in rotor columns, a
    type has at most 16 rotors, and a small gzip file may not inflate without bound."""
    for n, types in ((6, 1), (10, 1), (3, 100)):  # 100 types: 10^6 assignments of a shape
        for _, cells, _ in itertools.islice(pcs.structures(n, types, 16), 50):
            assert len(cells) * n * 16 <= pcs.BLOCK_COLUMNS
    many = impossible(2)
    t = many["types"][0]
    for key in ("positions", "directions"):
        t[key] = t[key] * 5  # 20 rotors
    t["spins"] = t["spins"] * 5
    with pytest.raises(pc.CertificateFormatError, match=r"types\[0\]: .* 1 to 16"):
        pc.check(many)
    path = tmp_path / "c.json.gz"
    path.write_bytes(gzip.compress(json.dumps(impossible(2)).encode()))
    monkeypatch.setattr(pcf, "MAX_TEXT", 100)
    with pytest.raises(pc.CertificateFormatError, match="more than 0 MiB of JSON"):
        pc.load(str(path))


def test_a_certificate_that_proves_nothing_is_refused():
    with pytest.raises(pc.CertificateFormatError, match="n_max: must be at least 1, not 0"):
        pc.check(impossible(0))


def test_what_the_oracle_accepts_off_range_is_no_certificate():
    """(fourth review) A force of 1e-10 along x, which no flat module exerts, is feasible by
    the oracle's off-range rule: the bounds once 'proved' that no number of modules does it;
    now the search answers one module, and the writer says in one line why that answer has no
    certificate (its residual is beyond the checker's 1e-11)."""
    from modquad_gym.geometry.module import palette

    problem = mq.SearchProblem(np.array([[1e-10, 0, 1.0, 0, 0, 0]]), n_max=4,
                               modules=palette("flat"))  # fmt: skip
    result = mq.exhaustive_search(problem)
    assert result.n_modules == 1 and result.certified
    with pytest.raises(certificates.CertificateError, match="off-range tolerance .* no certif"):
        certificates.make(result, problem)
