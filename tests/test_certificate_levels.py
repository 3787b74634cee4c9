"""A certificate's levels too large to prove (more than ``MAX_STRUCTURES`` structures and no
level bound covering them) are known before the search: ``modquad solve --certificate``
refuses at once when every certified answer's certificate would meet one, and says so in a
note when only a larger answer's would."""

from __future__ import annotations

import pytest

from modquad_gym.cli import main
from modquad_gym.cli import solve as solve_cli
from modquad_gym.geometry.module import palette
from modquad_gym.scoring.scale_tasks import draw
from modquad_gym.search import certificates
from modquad_gym.search.bounds import bound_levels
from modquad_gym.search.problem import SearchProblem
from modquad_gym.search.result import SearchResult
from modquad_gym.tasks import generated_task

TYPED = "t30,t45"
"""A palette whose count bound rules out levels that no single direction covers."""


@pytest.fixture(scope="module")
def planted14():
    return generated_task("planted", 2, "total", None, 14)  # planted-seed2, 14 modules


def test_a_certificate_that_must_be_refused_is_refused_before_the_search(
    planted14, tmp_path, monkeypatch, capsys
):
    """Every certified answer has at least the bound's 13 modules, so its certificate proves
    level 12, which holds millions of (shape, types) pairs and no level bound covers."""
    task, out = tmp_path / "p14.json", tmp_path / "c.json"
    planted14.save(task)

    def no_search(*args, **kwargs):
        raise AssertionError("the search ran")

    monkeypatch.setattr(solve_cli, "solver", no_search)
    argv = ["solve", "--task", str(task), "--modules", TYPED, "--n-max", "16", "--method",
            "exhaustive", "--certificate", str(out)]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "modquad: error: --certificate: level 12: no level bound covers it and it holds too "
        "many structures to prove one by one (at most 2,000,000)"
    )
    assert not out.exists()


def test_the_check_says_what_the_certificate_maker_does(planted14):
    """The refusal before the search is the maker's own, word for word (here the bounds alone
    prove no structure up to 12 modules: certified, and its certificate is refused); on each
    level too large to prove one by one, the check and the maker agree on whether a bound
    covers it."""
    problem = SearchProblem.build(planted14, 12, modules=palette(TYPED))
    with pytest.raises(certificates.CertificateError) as before:
        certificates.check_levels(problem)
    result = SearchResult(None, None, 0, 0, 0.0, None, "anytime", 12, lower_bound=13)
    with pytest.raises(certificates.CertificateError) as after:
        certificates.make(result, problem)
    assert str(before.value) == str(after.value) and "level 12" in str(before.value)
    one_type = SearchProblem.build(draw("torque", 48, 0, validation=True), 20)
    seen = set()
    for p, levels in ((problem, range(9, 13)), (one_type, range(14, 21))):
        refused = certificates.unprovable_levels(p, levels)
        parts = certificates._parts(p)
        for n in levels:
            prover = certificates._Prover(*parts, p)  # as at the maker's first level
            try:
                prover.level(n, progress=False)
                seen.add(False)
                assert n not in refused
            except certificates.CertificateError:
                seen.add(True)
                assert n in refused
    assert seen == {True, False}  # both outcomes met


def test_a_certificate_only_a_larger_answer_would_need_is_a_note(tmp_path, monkeypatch, capsys):
    """One type, bound 10 and n_max 16: an answer of at most 14 modules gets its certificate,
    a larger one (or none) would not; the search runs, after a note that says so."""
    task = draw("torque", 48, 0, validation=True)
    problem = SearchProblem.build(task, 16)
    assert bound_levels(problem) < 14 == certificates.check_levels(problem)
    path, out = tmp_path / "t.json", tmp_path / "c.json"
    task.save(path)

    def stop(*args, **kwargs):
        raise KeyboardInterrupt  # the search would start here

    monkeypatch.setattr(solve_cli, "solver", stop)
    argv = ["solve", "--task", str(path), "--n-max", "16", "--certificate", str(out)]
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert "--certificate: level 14 holds too many structures" in err
    assert "an answer of more than 14 modules, or of none up to 16, will be refused" in err
