"""Certificates (modquad_gym.search.certificates) and the independent checker
(modquad_gym.proofcheck): accepted for every kind of certified answer, rejected after any
single change with a message naming it; the checker's physics and enumeration
cross-checked against the package's."""

from __future__ import annotations

import ast
import copy
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym import proofcheck as pc
from modquad_gym import proofcheck_format as pcf
from modquad_gym import proofcheck_shapes as pcs
from modquad_gym.geometry.module import STOCK_TYPES, palette
from modquad_gym.geometry.polyominoes import A001168, PolyominoStream
from modquad_gym.search import certificate_directions as separations
from modquad_gym.search import certificates
from modquad_gym.search.problem import SearchProblem
from modquad_gym.tasks import load_suite

ROOT = Path(__file__).resolve().parents[1]
SUITES = ROOT / "modquad_gym" / "data" / "suites"


def certify(task, n_max=7, search=mq.exhaustive_search, **kw):
    problem = SearchProblem.build(task, n_max=n_max, **kw)
    result = search.solve(problem) if search is not mq.anytime_search else search.solve(
        problem, time_limit=20, seed=0)  # fmt: skip
    assert result.certified
    return json.loads(json.dumps(certificates.make(result, problem))), result


@pytest.fixture(scope="module")
def paper():
    """A paper-like task whose level 4 is proved structure by structure."""
    return certify(load_suite(SUITES / "heldout_paper.json")[1])


def test_the_checker_imports_only_numpy_and_the_standard_library(paper, tmp_path):
    """Its three files (the checker, its format and its shapes) import numpy, the standard
    library and each other; copied alone into a folder, they check a certificate without the
    package."""
    files = ("proofcheck", "proofcheck_format", "proofcheck_shapes")
    imported = {}
    for name in files:
        tree = ast.parse((ROOT / "modquad_gym" / f"{name}.py").read_text())
        imported[name] = {a.name.split(".")[0] for node in ast.walk(tree)
                          if isinstance(node, ast.Import) for a in node.names}  # fmt: skip
        imported[name] |= {node.module.split(".")[0] if node.module else a.name
                           for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                           for a in node.names}  # fmt: skip
    assert imported == {
        "proofcheck": {"__future__", "sys", "numpy", "proofcheck_format", "proofcheck_shapes",
                       "importlib", "pathlib"},
        "proofcheck_format": {"__future__", "gzip", "json", "math", "os", "stat", "zlib",
                              "numpy"},
        "proofcheck_shapes": {"__future__", "functools", "numpy"},
    }  # fmt: skip
    alone = tmp_path / "alone"
    alone.mkdir()
    for name in files:
        shutil.copy(ROOT / "modquad_gym" / f"{name}.py", alone / f"{name}.py")
    path = tmp_path / "c.json"
    path.write_text(json.dumps(paper[0]))
    code = (
        f"import sys; sys.path.insert(0, {str(alone)!r})\n"
        "import proofcheck as m\n"
        f"print(m.check(m.load({str(path)!r})))\n"
        "print(sorted(k for k in sys.modules if k.startswith('modquad')))\n"
    )
    run = dict(capture_output=True, text=True, check=True, cwd=tmp_path)
    out = subprocess.run([sys.executable, "-c", code], **run)
    assert out.stdout.startswith("valid: the minimum is 5 modules")
    assert out.stdout.splitlines()[-1] == "[]"
    for isolated in ([], ["-I"]):  # -I: the script's folder is not on sys.path
        out = subprocess.run([sys.executable, *isolated, str(alone / "proofcheck.py"), str(path)],
                             **run)  # fmt: skip
        assert out.stdout.startswith("valid: the minimum is 5 modules")


def test_the_checker_enumerates_every_structure_once():
    for n in range(1, 9):
        assert len(pcs.shape_keys(n)) == A001168[n - 1]
    for n in range(1, 7):  # the same sets as the package's Redelmeier enumeration
        ours = set(pcs.shape_keys(n).tolist())
        theirs = np.concatenate(list(PolyominoStream(n, 4096))).astype(np.int64)
        assert set(pcs.keys_of(theirs).tolist()) == ours
    cells = pcs.cells_of(pcs.shape_keys(5), 5)
    assert np.array_equal(pcs.keys_of(cells), pcs.shape_keys(5))


def test_the_checker_physics_is_the_package_physics():
    rng = np.random.default_rng(0)
    types = palette("t45,t45m,flat")
    T = pc.Types([certificates.type_dict(m) for m in types])
    heavy = mq.ModuleType.from_tilts((0.3, -0.2, 0.1, 0.5), mass=0.9, name="heavy")
    T2 = pc.Types([certificates.type_dict(m) for m in (STOCK_TYPES["t30"], heavy)])
    for Tk, pal in ((T, types), (T2, [STOCK_TYPES["t30"], heavy])):
        cells = pcs.cells_of(pcs.shape_keys(6), 6)[rng.choice(216, 8, replace=False)]
        kinds = rng.integers(0, len(pal), (8, 6))
        a, M, j = Tk.columns(cells.astype(float), kinds)
        for k in range(8):
            s = mq.Structure(cells[k].tolist(), modules=[pal[t] for t in kinds[k]])
            assert np.allclose(a[k].T, s.configuration_matrix(), atol=1e-12)
            assert np.isclose(M[k], s.mass)
            J = s.inertia
            want = [J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[0, 2], J[1, 2]]
            assert np.allclose(j[k], want, atol=1e-12)


def test_separations_agree_with_the_oracle_on_random_structures():
    """A direction the checker accepts always comes with an infeasible wrench (oracle), and
    the oracle's infeasible wrenches get a direction the checker accepts."""
    rng = np.random.default_rng(1)
    T = pc.Types([certificates.type_dict(mq.TModule())])
    for n in (1, 2, 4, 6):  # 1 and 2 modules and lines: rank-deficient matrices
        cells = pcs.cells_of(pcs.shape_keys(n), n)
        for k in rng.choice(len(cells), min(len(cells), 4), replace=False):
            a, _, _ = T.columns(cells[k : k + 1].astype(float), np.zeros((1, n), int))
            A = a[0].T
            W = (A @ rng.uniform(-0.3, 1.3, (A.shape[1], 12))).T  # near the boundary, both sides
            ok = mq.feasible(A, W)
            for i in range(len(W)):
                found = next(separations.candidates(A, W[i : i + 1], 1.0), None)
                assert (found is None) == bool(ok[i])
                if found is not None:
                    d = found[0][None]
                    assert pc.separation(a, W[i : i + 1], d, 1.0)[0] > 0
            for d in rng.normal(size=(20, 6)):  # any accepted direction proves infeasibility
                sep = pc.separation(np.repeat(a, len(W), 0), W, np.tile(d, (len(W), 1)), 1.0)
                assert not np.any(ok & (sep > 0))


def test_a_level_bound_never_undercuts_a_structure_of_its_level():
    """The bound's capacity is at least every structure's support (random directions, every
    structure of levels 2-5 of mixed types)."""
    rng = np.random.default_rng(2)
    pal = palette("t45,flat")
    T = pc.Types([certificates.type_dict(m) for m in pal])
    zero = np.zeros((1, 6))
    for n in (2, 3, 5):
        for d in rng.normal(size=(6, 6)):
            worst = -np.inf
            for _, cells, types in pc.structures(n, 2, T.rotors):
                a, _, _ = T.columns(cells.astype(float), types)
                worst = max(worst, float(pc.support_terms(a @ d).sum(axis=1).max()))
            task = (d[None] * worst / (d @ d), zero, np.zeros((1, 6, 6)))  # d . w = worst
            assert pc.bound_margin(T, task, 1.0, None, n, d, 0) <= 0
            task = (d[None] * (worst + 1e-3) / (d @ d), zero, np.zeros((1, 6, 6)))
            if pc.bound_margin(T, task, 1.0, None, n, d, 0) > 0:  # sound when it claims
                assert worst < d @ task[0][0]


@pytest.mark.parametrize("case", ["exhaustive", "anytime", "palette", "dynamic", "rotor", "module"])
def test_certified_answers_have_certificates_the_checker_accepts(case):
    if case == "palette":
        task = load_suite(SUITES / "mixed_external.json")[2]
        cert, r = certify(task, modules=palette("t45,t45m,flat"))
    elif case == "dynamic":
        cert, r = certify(load_suite(SUITES / "dynamic_motions.json")[0])
    elif case in ("rotor", "module"):
        cert, r = certify(load_suite(SUITES / "heldout_planted.json")[1], fault=case)
    else:
        search = mq.anytime_search if case == "anytime" else mq.exhaustive_search
        cert, r = certify(load_suite(SUITES / "heldout_planted.json")[0], search=search)
    assert pc.check(cert).startswith("valid")
    assert cert["minimum"] == r.n_modules
    if case in ("palette", "dynamic"):  # some level proved structure by structure
        assert any("direction" in e for e in cert["levels"])


def test_no_structure_up_to_n_max_is_certified_too():
    cert, r = certify(load_suite(SUITES / "heldout_planted.json")[0], n_max=4)
    assert r.structure is None and cert["minimum"] is None
    assert pc.check(cert) == (
        "valid: no structure of up to 4 modules satisfies the task 'planted-1000000'"
    )


def _mutations(cert):
    """(name, mutated certificate, words the message must hold) for single changes."""
    level = next(e for e in cert["levels"] if "direction" in e)
    out = []

    def mutant(name, change, words):
        c = copy.deepcopy(cert)
        change(c, next(e for e in c["levels"] if e["n"] == level["n"]))
        out.append((name, c, words))

    def perturb(c, e):
        p = e["direction"][0]
        c["directions"][p] = (np.array(c["directions"][p]) + [0, 0, 0, 0.5, -0.5, 0]).tolist()

    def swap(c, e):
        w = c["task"]["base"]
        w[0], w[-1] = w[-1], w[0]

    def smaller(c, e):
        c["minimum"] -= 1
        c["answer"]["cells"].pop()
        c["answer"]["types"].pop()

    def scale_u(c, e):
        u = c["answer"]["allocations"][0][0]
        u[0] += 1e-4

    mutant("perturbed direction", perturb, f"level {level['n']}: structure")
    mutant("removed structure", lambda c, e: (e["direction"].pop(), e["wrench"].pop()),
           f"level {level['n']}: direction")  # fmt: skip
    mutant("changed allocation", scale_u, "answer: allocation")
    mutant("swapped wrench", swap, "answer: allocation")
    mutant("smaller answer claimed", smaller, "answer")
    mutant("changed f_max", lambda c, e: c.__setitem__("f_max", c["f_max"] * 0.9), "answer")
    mutant("missing level", lambda c, e: c["levels"].remove(e), f"level {level['n']}: no proof")
    mutant("wrong wrench", lambda c, e: e["wrench"].__setitem__(0, (e["wrench"][0] + 1) % len(
        c["task"]["base"])), f"level {level['n']}")  # fmt: skip
    mutant("changed drag", lambda c, e: c["types"][0].__setitem__("c_tau", 0.05), "answer")
    return out


def test_every_single_change_is_rejected_with_a_message_naming_it(paper):
    cert = paper[0]
    assert pc.check(cert).startswith("valid")
    for name, mutated, words in _mutations(cert):
        with pytest.raises(pc.ProofError) as info:
            pc.check(mutated)
        assert words in str(info.value), (name, str(info.value))


def test_a_bound_changed_or_a_failure_swapped_is_rejected():
    cert, _ = certify(load_suite(SUITES / "heldout_planted.json")[1], fault="rotor")
    bounded = next(e for e in cert["levels"] if "bound" in e)
    c = copy.deepcopy(cert)
    c["directions"][bounded["bound"]["direction"]] = [0, 0, -1.0, 0, 0, 0]  # down: no bound
    with pytest.raises(pc.ProofError, match=f"level {bounded['n']}: bound"):
        pc.check(c)
    c = copy.deepcopy(cert)
    c["fault"] = None  # without a fault, a level has no failures
    with pytest.raises(pc.CertificateFormatError, match=r"levels\[\d+\]: unknown key 'failure'"):
        pc.check(c)
    for e in c["levels"]:
        e.pop("failure", None)
    with pytest.raises(pc.ProofError, match="answer.allocations"):  # one, not one per failure
        pc.check(c)


def test_modquad_check_exit_codes(paper, tmp_path, capsys):
    from modquad_gym.cli import main

    good, bad = tmp_path / "c.json.gz", tmp_path / "bad.json"
    import gzip

    with gzip.open(good, "wt") as fh:
        json.dump(paper[0], fh)
    assert main(["check", str(good)]) == 0
    assert capsys.readouterr().out.startswith("valid")
    c = copy.deepcopy(paper[0])
    c["answer"]["cells"][0][0] += 7  # disconnected
    bad.write_text(json.dumps(c))
    assert main(["check", str(bad)]) == 1
    assert "invalid: answer" in capsys.readouterr().out
    bad.write_text('{"format": "something else"}')
    assert main(["check", str(bad)]) == 2
    assert "not a modquad-certificate" in capsys.readouterr().err


def test_modquad_check_levels_prints_each_level_on_stdout(paper, tmp_path, capsys):
    """``--levels`` asks for the levels' lines: on stdout with the verdict (``> levels.txt``
    keeps them), one per level proved, before it; stderr stays for errors."""
    from modquad_gym.cli import main

    path = tmp_path / "c.json"
    path.write_text(json.dumps(paper[0]))
    assert main(["check", str(path), "--levels"]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    proved = [e["n"] for e in paper[0]["levels"]]
    assert [int(line.split(":")[0].removeprefix("level ")) for line in lines[:-1]] == proved
    assert lines[-1].startswith("valid") and err == ""


@pytest.mark.parametrize("fault", ["rotor2", "rotor+module"])
def test_a_fault_no_certificate_covers_is_refused_before_the_search(fault, tmp_path, capsys):
    """Both doors say the same words: the CLI refuses before any search (no answer printed,
    no file), ``certificates.make`` refuses the same fault in Python."""
    from modquad_gym.cli import main

    out = tmp_path / "proof.json"
    argv = ["solve", "--task", "example:screwdriver", "--fault", fault, "--certificate", str(out)]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert f"certificates cover fault rotor or module, not {fault!r}" in captured.err
    assert "modules" not in captured.out and not out.exists()
    with pytest.raises(certificates.CertificateError, match="cover fault rotor or module"):
        certificates.check_fault(fault)


def test_a_margin_after_the_failure_is_refused_before_the_search(tmp_path, capsys):
    """The format proves survival, not a margin: a certificate of a margin-0 claim beside an
    answer asked to keep one would prove less than the answer claims."""
    from modquad_gym.cli import main

    out = tmp_path / "proof.json"
    for extra in (["--fault-margin", "0.2"], ["--detection-delay", "0.03"]):
        argv = ["solve", "--task", "example:screwdriver", "--fault", "rotor", *extra,
                "--certificate", str(out)]  # fmt: skip
        assert main(argv) == 2
        captured = capsys.readouterr()
        assert captured.err.count("\n") == 1 and "not a margin after it" in captured.err
        assert "modules" not in captured.out and not out.exists()
    with pytest.raises(certificates.CertificateError, match="not a margin after it"):
        certificates.check_fault("rotor", 0.2)
    certificates.check_fault("rotor", 0.0)  # no margin: covered


RESULTS = ROOT / "results" / "certificates"


def test_the_committed_certificates_check_and_a_sample_regenerates_alike(tmp_path):
    """The benchmark's certificates: the sample files committed with it have the sha256 of
    hashes.csv and the checker accepts them; two rows made again here give the same minimum
    and the same proof of each level (bytes may differ across CPUs in the last bits)."""
    import csv
    import gzip
    import hashlib

    from benchmarks.certificates import certify

    rows = list(csv.DictReader((RESULTS / "hashes.csv").open()))
    committed = [r for r in rows if (RESULTS / r["file"]).exists()]
    assert committed
    for r in committed:
        data = (RESULTS / r["file"]).read_bytes()
        assert hashlib.sha256(data).hexdigest() == r["sha256"]
        assert pc.check(json.loads(gzip.decompress(data))).startswith("valid")
    for r in (rows[0], next(r for r in rows if r["tier"] == "mixed")):
        task = next(t for t in load_suite(SUITES / f"{r['suite']}.json") if t.name == r["task"])
        modules = "t45,t45m,flat" if r["tier"] == "mixed" else None
        again = certify(r["tier"], r["suite"], task, 7, modules, r["fault"] or None, tmp_path)
        assert again["valid"] and str(again["minimum"]) == r["minimum"]
        assert again["levels"] == r["levels"]


def test_modquad_solve_writes_a_certificate_that_checks(tmp_path, capsys):
    from modquad_gym.cli import main

    task = tmp_path / "task.json"
    task.write_text(json.dumps({"wrenches": [[0, 0, 5.0, 0, 0, 0], [0.4, 0, 4.0, 0, 0, 0.05]]}))
    out = tmp_path / "proof.json.gz"
    args = ["solve", "--task", str(task), "--method", "exhaustive", "--n-max", "5", "--json"]
    assert main([*args, "--certificate", str(out)]) == 0
    capsys.readouterr()
    assert main(["check", str(out)]) == 0
    assert capsys.readouterr().out.startswith("valid: the minimum is 2 modules")
    assert main([*args, "--certificate", str(out)]) == 2  # kept unless --force
    assert "--certificate" in capsys.readouterr().err
    assert main([*args, "--certificate", str(tmp_path / "proof.txt")]) == 2
    assert ".json or .json.gz" in capsys.readouterr().err
    problem = SearchProblem.build(json.loads(task.read_text())["wrenches"], n_max=5)
    result = mq.exhaustive_search.solve(problem)
    assert pc.check(result.certificate(problem)).startswith("valid")


def test_a_malformed_certificate_is_named_in_one_line(paper, tmp_path, capsys):
    from modquad_gym.cli import main

    level = next(e["n"] for e in paper[0]["levels"] if "direction" in e)
    changes = {
        "types": lambda c: c.pop("types"),
        "task.base": lambda c: c["task"].__setitem__("base", [["a"] * 6]),
        f"level {level}: direction": lambda c: next(
            e for e in c["levels"] if e["n"] == level)["direction"].__setitem__(0, "x"),
        "fault": lambda c: c.__setitem__("fault", "rotor3"),
    }  # fmt: skip
    for words, change in changes.items():
        c = copy.deepcopy(paper[0])
        change(c)
        path = tmp_path / "bad.json"
        path.write_text(json.dumps(c))
        assert main(["check", str(path)]) == 2, words
        err = capsys.readouterr().err
        assert err.startswith("modquad: error: ") and words in err and len(err.splitlines()) == 1


def test_not_a_number_never_passes(paper):
    """NaN compares false both ways: a NaN thrust, bound or direction must still fail."""
    c = copy.deepcopy(paper[0])
    c["answer"]["allocations"][0][0][0] = float("nan")
    with pytest.raises(pc.ProofError, match="not a finite number"):
        pc.check(c)
    c = copy.deepcopy(paper[0])
    c["directions"][0][0] = float("nan")
    with pytest.raises(pc.CertificateFormatError, match="directions"):
        pc.check(c)
    c = copy.deepcopy(paper[0])
    c["types"][0]["directions"][0] = [0.0, 0.0, 0.0]
    unit = r"types\[0\]\.directions\[0\]: rotor 1's thrust direction must be a unit vector"
    with pytest.raises(pc.CertificateFormatError, match=unit):
        pc.check(c)
    bounded = next(e for e in c["levels"] if "bound" in e)
    T = pc.Types(paper[0]["types"])
    task = pcf.task_model(paper[0]["task"])
    d = np.array(paper[0]["directions"][bounded["bound"]["direction"]])
    assert not pc.bound_margin(T, task, np.nan, None, bounded["n"], d, 0) > 0
