"""What the pages say a quantity or a method is, as the code has it: the margin's gamma is the
gauge about hover at half thrust (``mq.margin``'s docstring), and "certified" describes a method
unqualified only where its registry entry certifies."""

from __future__ import annotations

import re
from pathlib import Path

import modquad_gym as mq
from modquad_gym.methods import REGISTRY

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")), ROOT / "results" /
         "leaderboard.md"]  # fmt: skip
PAGES = [p for p in PAGES if p.name != "changelog.md"]
GAMMA_DEFINED = re.compile(r"(?:γ|\bgamma\b)(?:\(w\))?(?: of a wrench w)? is (?:the|its)\b[^.]*")
QUALIFIED = re.compile(r"certified (?:where|when)\b")
GUIDED_WORDS = "certified where its answer meets the lower bound"


def _flat(text: str) -> str:
    return " ".join(re.sub(r"<!--.*?-->", "", text, flags=re.S).split())


def test_every_page_that_defines_gamma_says_the_gauge_about_half_thrust():
    assert "half thrust" in mq.margin.__doc__
    found = [(p, m.group(0)) for p in PAGES for m in GAMMA_DEFINED.finditer(_flat(p.read_text()))]
    assert len({p for p, _ in found}) >= 3, found  # oracle.md, faults.md, getting-started
    for page, definition in found:
        assert "half thrust" in definition, (page.relative_to(ROOT).as_posix(), definition)


def test_a_method_is_described_certified_unqualified_only_where_its_entry_certifies():
    """The registry's words (``--method`` help, the docs' method table): "certified" beside a
    method that does not prove its answers says where it does."""
    for method in REGISTRY.values():
        for m in re.finditer(r"certified", method.help):
            assert method.certifies or QUALIFIED.match(method.help, m.start()), method.name
    assert not REGISTRY["ppo-guided"].certifies
    assert GUIDED_WORDS in REGISTRY["ppo-guided"].help


def test_the_pages_describe_the_guided_search_in_its_registry_words():
    """Where a page names the policy-guided search and calls it certified (before the sentence
    ends, within 120 characters), it says where."""
    said = 0
    for page in PAGES:
        text = _flat(page.read_text())
        for m in re.finditer(r"ppo-guided|policy-guided", text):
            clause = re.split(r"\.\s", text[m.start() : m.start() + 120])[0]
            if "certified" in clause:
                said += 1
                rest = text[m.start() : m.start() + 200]
                assert GUIDED_WORDS in rest, (page.relative_to(ROOT).as_posix(), clause)
    assert said >= 4  # README, results, agents, leaderboard pages


def test_the_exhaustive_search_says_what_its_answers_are():
    """Its docstring said ``certified`` is always True and an infeasible answer's bound is
    n_max + 1: with ``start`` an answer may be uncertified, and past n_max the exact bounds may
    prove more (review 22)."""
    doc = " ".join(mq.exhaustive_search.__doc__.split())
    assert "always True" not in doc and "n_max + 1)" not in doc
    far = mq.exhaustive_search([[0.0, 0.0, 9.0, 0.0, 0.0, 0.0]], n_max=1)
    assert far.certified and far.lower_bound > 2
    assert "n_max + 1, or more where the exact bounds prove more" in doc
    part = mq.exhaustive_search([[0.0, 0.0, 2.0, 0.0, 0.0, 0.0]], n_max=3, start=[(0, 0), (1, 0)])
    assert part.structure is not None and not part.certified
    assert "Without ``start`` it is certified" in doc and "with ``start``, as below" in doc


def test_faults_page_says_which_failures_the_intact_minimum_flies():
    """docs/faults.md describes the intact minimum's flights as ``others_choice`` chooses them:
    its own failures (every one under ``all``, its smallest-margin one under ``worst`` or a
    number), never "the same failure" as the found structure's."""
    from modquad_gym.sim.validate_fault import others_choice

    page = _flat((ROOT / "docs" / "faults.md").read_text())
    assert "same failure is flown on the intact minimum" not in page
    said = re.search(r"The intact minimum of the task[^.]*\.", page)
    assert said, "faults.md: no sentence on the intact minimum's flights"
    assert others_choice("all") == "all" and "every one under `--failure all`" in said.group(0)
    assert others_choice("worst") == others_choice(3) == "worst"
    assert "smallest-margin one under `--failure worst` or `--failure K`" in said.group(0)
