"""Benchmark tiers: registered environments, shipped suites with certified optima, scoring."""

from __future__ import annotations

import csv

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.dynamics.trajectory import FIELDS
from modquad_gym.scoring.agents import main as bench_main
from modquad_gym.scoring.tiers import TIERS, build_tier_suite, get_tier
from modquad_gym.search import verified


@pytest.mark.parametrize("name", list(TIERS))
def test_tier_env_plays_and_its_suites_carry_optima(name):
    tier = TIERS[name]
    env = gym.make(tier.env_id, **tier.env_kwargs)
    assert env.unwrapped.n_max == tier.n_max
    env.reset(seed=0)
    valid = np.flatnonzero(env.unwrapped.action_masks())
    env.step(int(valid[0]))
    env.close()
    suites = tier.load_suites()
    assert suites
    for tasks in suites.values():
        assert all(t.meta["optimum_n_max"] == tier.n_max for t in tasks)
        # planted tasks always have an optimum; a random motion may be too fast for 7 modules
        in_scope = [t for t in tasks if t.meta["optimum"] is not None]
        assert len(in_scope) >= 40 and len(in_scope) >= 0.9 * len(tasks)


def assert_same_draw(a, b):
    """The same seeded draw: floating point differs in the last bits between CPUs (an Intel and
    an AMD machine disagree by ~1e-14 here), so within a tolerance, not bit for bit."""
    close = dict(rtol=1e-12, atol=1e-12)
    assert type(a) is type(b) and a.kind == b.kind and a.f_max == b.f_max
    if isinstance(a, mq.DynamicTask):
        for field in FIELDS:
            np.testing.assert_allclose(getattr(b.trajectory, field),
                                       getattr(a.trajectory, field), **close)  # fmt: skip
        assert (a.payload is None) == (b.payload is None)
        if a.payload is not None:
            assert b.payload.mass == pytest.approx(a.payload.mass, rel=1e-12)
            np.testing.assert_allclose(b.payload.offset, a.payload.offset, **close)
        assert (a.exerted is None) == (b.exerted is None)
        if a.exerted is not None:
            np.testing.assert_allclose(b.exerted, a.exerted, **close)
    else:
        np.testing.assert_allclose(b.wrenches, a.wrenches, **close)


@pytest.mark.parametrize("name", ["large", "mixed", "dynamic"])
def test_shipped_tier_suites_are_reproduced_from_their_seeds(name):
    tier = TIERS[name]
    shipped = tier.load_suites(limit=2)[tier.suites[0]]
    rebuilt = build_tier_suite(tier, 2, progress=False)
    for a, b in zip(shipped, rebuilt, strict=True):
        assert_same_draw(a, b)
        # the certified optimum is recomputed from the rebuilt task and must match exactly
        assert a.meta["optimum"] == b.meta["optimum"]


def test_mixed_tier_optima_are_feasible_with_their_own_weight():
    tier = TIERS["mixed"]
    types = {m.name: m for m in tier.search_kwargs()["modules"]}
    for task in tier.load_suites(limit=10)["mixed_external"]:
        cells = [tuple(c) for c in task.meta["optimum_cells"]]
        s = mq.Structure(cells, modules=[types[n] for n in task.meta["optimum_modules"]])
        assert s.n_modules == task.meta["optimum"]
        assert task.kind == "external" and verified(s, task)


def test_unknown_tier_is_one_clear_error():
    with pytest.raises(ValueError, match="unknown tier 'huge'"):
        get_tier("huge")


def test_bench_agents_scores_the_mixed_tier(tmp_path):
    out = tmp_path / "rep"
    code = bench_main(["--tier", "mixed", "--methods", "exhaustive", "greedy", "--limit", "3",
                       "--out", str(out), "--no-progress"])  # fmt: skip
    assert code == 0
    with open(out / "benchmark.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    exhaustive = [r for r in rows if r["method"] == "exhaustive"]
    assert len(exhaustive) == 3
    assert all(r["success"] == "1" and r["optimal"] == "1" for r in exhaustive)
    assert all(r["success"] == "0" or int(r["gap"]) >= 0 for r in rows)
