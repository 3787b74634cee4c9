"""Certificates at the edges of what they prove: a smaller structure just beyond the proofs'
band (certified where a direction exists, refused in one line naming the structure and the
wrench where none can), thrust directions that are not unit vectors, the tolerances as
docs/certificates.md writes them, and a task whose products of inertia enter its wrenches."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import dynamics as dy
from modquad_gym import proofcheck as pc
from modquad_gym.cli import main
from modquad_gym.geometry.module import palette
from modquad_gym.search import certificates
from modquad_gym.search.problem import SearchProblem

ROOT = Path(__file__).resolve().parents[1]
ONE = mq.Structure([(0, 0)]).configuration_matrix()
LIFT = ONE.sum(axis=1)
"""One T-module's four rotors at full thrust: a pure lift (0, 0, 2.828..., 0, 0, 0)."""
CORNER = ONE[:, 1:].sum(axis=1)
"""Three of its rotors at full thrust, the first idle: a vertex with a torque."""


def certificate(wrenches, n_max=3):
    """(certified result, a maker of its certificate as JSON gives it) of a task or wrenches."""
    task = wrenches if isinstance(wrenches, dy.DynamicTask) else np.atleast_2d(wrenches)
    problem = SearchProblem.build(task, n_max=n_max)
    result = mq.exhaustive_search.solve(problem)
    assert result.certified
    return result, lambda: json.loads(json.dumps(certificates.make(result, problem)))


@pytest.mark.parametrize("vertex", [LIFT, CORNER], ids=["lift", "corner"])
def test_band_a_structure_just_beyond_the_band_is_proved(vertex):
    """(review 22) The oracle's LP dual of one module beyond a vertex separates 8 times less
    than the best direction, too little for the maker's strict test, which once refused; the
    push of the rotors beyond the band separates it."""
    result, make = certificate((1 + 5.02e-7) * vertex)
    assert result.n_modules == 2
    cert = make()
    assert pc.check(cert).startswith("valid: the minimum is 2 modules")
    assert cert["levels"] == [{"n": 1, "direction": [0], "wrench": [0]}]


def test_band_within_the_band_the_refusal_names_the_structure_and_the_wrench(tmp_path, capsys):
    """Thrusts 5.005e-7 f_max beyond the box: the oracle rejects them, the proofs cannot (B =
    5.01e-7), so no certificate exists, and the refusal says so, naming wrench row 2."""
    W = np.array([0.5 * LIFT, (1 + 5.005e-7) * LIFT])
    result, make = certificate(W)
    assert result.n_modules == 2
    words = (
        r"the structure \[\[0, 0\]\] \(types \[0\]\) reaches wrench row 2 of the task .* only "
        r"with thrusts 5\.005e-07 f_max beyond \[0, f_max\]: the oracle rejects it \(beyond its "
        r"5e-07\) but the proofs exclude only thrusts beyond 5\.01e-07 f_max, so no certificate "
        r"exists"
    )
    with pytest.raises(certificates.CertificateError, match=words):
        make()
    task = tmp_path / "edge.json"
    task.write_text(json.dumps({"wrenches": W.tolist(), "f_max": 1.0}))
    args = ["solve", "--task", str(task), "--method", "exhaustive", "--n-max", "3"]
    assert main([*args, "--certificate", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(words, err), err
    assert not (tmp_path / "c.json").exists()


def test_band_with_a_fault_a_structure_is_proved_intact_or_after_a_failure():
    """Proved structure by structure (no level bounds), under fault rotor: one module beyond
    its corner by 5.02e-7 is proved intact by the push of its rotors, by 5.005e-7 (within the
    band intact) after a rotor failure; two modules whose best failure leaves them within the
    band are refused, naming the failure and the wrench, and so are two modules just beyond it
    (no direction tried separates them)."""
    for e, failure in ((5.02e-7, -1), (5.005e-7, 2)):
        problem = SearchProblem.build(((1 + e) * CORNER)[None], n_max=3, fault="rotor")
        result = mq.exhaustive_search.solve(problem)
        cert = json.loads(json.dumps(certificates.make(result, problem, bounds=False)))
        assert pc.check(cert).startswith("valid: the minimum is 3 modules")
        assert cert["levels"][0]["failure"] == [failure]
    problem = SearchProblem.build(((1 + 5.005e-7) * LIFT)[None], n_max=3, fault="rotor")
    result = mq.exhaustive_search.solve(problem)
    words = (
        r"the structure \[\[0, 0\], \[0, 1\]\] \(types \[0, 0\]\), after rotor \d \(1-based\) "
        r"fails, reaches wrench row 1 of the task .* so no certificate exists"
    )
    with pytest.raises(certificates.CertificateError, match=words):
        certificates.make(result, problem, bounds=False)
    problem = SearchProblem.build(((1 + 5.02e-7) * LIFT)[None], n_max=3, fault="rotor")
    result = mq.exhaustive_search.solve(problem)
    words = (  # docs/certificates.md: not every direction is tried
        r"after rotor \d \(1-based\) fails, reaches wrench row 1 of the task .* only with thrusts "
        r"5\.02\d*e-07 f_max beyond \[0, f_max\], so close .* no direction tried .* separates it"
    )
    with pytest.raises(certificates.CertificateError, match=words):
        certificates.make(result, problem, bounds=False)


def test_band_thresholds_stated_in_the_docs():
    """docs/certificates.md: for one T-module's lift times 1 + e, a certificate exists only
    above e = 5.0112e-7 (where the lift direction, the best one there, separates it) and the
    maker writes one only above e = 5.0148e-7 (its factor STRICT = 4 on the checker's
    tolerance)."""
    T = pc.Types([certificates.type_dict(mq.TModule())])
    a, _, _ = T.columns(np.zeros((1, 1, 2)), np.zeros((1, 1), int))
    up = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]])
    for e, separates in ((5.0112e-7, False), (5.0113e-7, True)):
        assert (pc.separation(a, (1 + e) * LIFT[None], up, 1.0)[0] > 0) == separates
    text = (ROOT / "docs" / "certificates.md").read_text()
    assert "a certificate exists only above e = 5.0112e-7" in text
    assert "the maker writes one only above e = 5.0148e-7" in text
    assert certificates.STRICT == 4.0
    with pytest.raises(certificates.CertificateError, match="4 times the checker's tolerance"):
        certificate((1 + 5.0148e-7) * LIFT)[1]()
    assert pc.check(certificate((1 + 5.0149e-7) * LIFT)[1]()).startswith("valid")


def test_thrust_directions_must_be_unit_vectors():
    """(review 22) A direction of length 0.5 was rescaled silently, although the format says
    unit directions; now it is refused naming the type and the rotor. Round-off is not."""
    _, make = certificate(2.0 * LIFT)
    cert = make()
    bad = copy.deepcopy(cert)
    bad["types"][0]["directions"][2] = (np.array(cert["types"][0]["directions"][2]) / 2).tolist()
    words = (
        r"^types\[0\]\.directions\[2\]: rotor 3's thrust direction must be a unit vector "
        r"\(length within 1e-12 of 1\), not of length 0\.5\d*$"
    )
    with pytest.raises(pc.CertificateFormatError, match=words):
        pc.check(bad)
    close = copy.deepcopy(cert)
    close["types"][0]["directions"][2] = (
        np.array(cert["types"][0]["directions"][2]) * (1 + 1e-13)
    ).tolist()
    assert pc.check(close).startswith("valid")


def _docs_formulas() -> dict:
    text = (ROOT / "docs" / "certificates.md").read_text()
    block = next(b for b in re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)
                 if "def residual_allowed" in b)  # fmt: skip
    namespace: dict = {}
    exec(block, namespace)
    return namespace


def test_the_docs_tolerances_are_the_checkers():
    """docs/certificates.md's lines for the answer's allowance and the separation margin give
    the checker's numbers on the structures of a level (with failed rotors left out)."""
    docs = _docs_formulas()
    rng = np.random.default_rng(0)
    T = pc.Types([certificates.type_dict(m) for m in palette("t45,flat")])
    for _, cells, types in pc.structures(3, T.n, T.rotors):
        a, M, j, j_size = T.columns(cells.astype(float), types, sizes=True)
        task = (rng.normal(size=(1, 6)), rng.normal(size=(1, 6)), rng.normal(size=(1, 6, 6)))
        i = np.zeros(len(cells), int)
        W, S = pc.wrenches(task, i, M, j), pc.wrenches(task, i, M, j_size, size=True)
        D = pc.scaled(rng.normal(size=W.shape))
        off = rng.random(a.shape[:2]) < 0.2
        want = pc.separation(a, W, D, 1.0, off=off, size=S)
        for k in range(len(cells)):
            got = docs["separation_margin"](a[k], W[k], S[k], D[k], failed=off[k])
            assert np.isclose(got, want[k], rtol=0, atol=1e-12 * (1 + abs(want[k])))
            A = a[k][~off[k]].T
            allowed = pc.residual_allowed(A, W[k][None], S[k][None], 1.0)[0]
            assert np.array_equal(docs["residual_allowed"](A, W[k], S[k]), allowed)
    assert (docs["THRUST_TOL"], docs["PROOF_BAND"]) == (pc.THRUST_TOL, pc.PROOF_BAND)


def test_a_rocking_motion_exercises_the_products_of_inertia():
    """(review 22) No certificate had a non-zero Jxy column: a motion rocking about (1, 1, 0)
    has one, its L-shaped answer a non-zero Jxy; the checker's wrenches are the package's
    Newton-Euler wrenches for every structure of a level, and the wrong sign is rejected."""
    t = np.linspace(0.0, 2.0, 41)
    angle = 0.3 * np.sin(np.pi * t)
    axis = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    q = np.column_stack([np.cos(angle / 2), np.sin(angle / 2)[:, None] * axis])
    traj = mq.Trajectory(t, np.zeros((len(t), 3)), quaternion=q)
    task = dy.DynamicTask(traj, f_max=2.0, name="rocking")
    _, make = certificate(task, n_max=6)
    cert = make()
    assert pc.check(cert).startswith("valid: the minimum is 3 modules")
    assert np.abs(np.array(cert["task"]["per_inertia"])[:, :, 3]).max() > 1.0
    model = pc.fmt.task_model(cert["task"])
    T = pc.Types(cert["types"])
    for _, cells, types in pc.structures(3, 1, T.rotors):
        _, M, j = T.columns(cells.astype(float), types)
        for k in range(len(cells)):
            ours = pc.wrenches(model, np.arange(len(model[0])), np.full(len(model[0]), M[k]),
                               np.tile(j[k], (len(model[0]), 1)))  # fmt: skip
            theirs = mq.required_wrenches(mq.Structure(cells[k].tolist()), traj)
            gaps = np.abs(theirs[:, None, :] - ours[None]).max(axis=2).min(axis=1)
            assert gaps.max() < 1e-12 * np.abs(theirs).max()  # every sample is a row
    assert mq.Structure([tuple(c) for c in cert["answer"]["cells"]]).inertia[0, 1] != 0
    flipped = copy.deepcopy(cert)
    for row in flipped["task"]["per_inertia"]:
        for q in range(6):
            row[q][3] = -row[q][3]
    with pytest.raises(pc.ProofError, match="answer: allocation: wrench"):
        pc.check(flipped)
