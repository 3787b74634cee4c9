"""A model's own shortlist: the learned solvers decide exactly, by default, the ``top_k`` its
config.json names (the mixed tier's model, three module types: chosen on the tier's validation
tasks, ``results/lookahead_top_k_mixed/``), else :data:`~modquad_gym.policy.models.TOP_K`; a
``top_k`` given still wins, and a bad one in config.json is one line naming the file."""

from __future__ import annotations

import json
import shutil

import pytest

from modquad_gym.cli import main
from modquad_gym.geometry.module import palette
from modquad_gym.policy.models import DEFAULT_MODEL, TOP_K
from modquad_gym.scoring.tiers import TIERS
from modquad_gym.solvers import make_solver

MIXED = TIERS["mixed"]
MIXED_TYPES = palette(MIXED.modules)


def shortlist(method: str, model=None, modules=None, **options) -> int | None:
    """The ``lookahead_top_k`` the solver's policy acts with (None: every child)."""
    solver = make_solver(method, 7, model=model, modules=modules, **options)
    return solver.inner(7, modules).policy.env_kwargs.get("lookahead_top_k")


@pytest.mark.parametrize("method", ["ppo", "ppo-guided"])
def test_the_mixed_model_acts_with_the_shortlist_its_config_names(method):
    own = json.loads(MIXED.model.with_name("config.json").read_text())["top_k"]
    assert own != TOP_K  # chosen for its palette, not the one-type models' k
    assert shortlist(method, str(MIXED.model), MIXED_TYPES) == own
    assert shortlist(method, str(MIXED.model), MIXED_TYPES, top_k=TOP_K) == TOP_K  # given: wins
    assert shortlist(method, str(MIXED.model), MIXED_TYPES, top_k=None) is None


def test_a_model_without_its_own_keeps_the_default():
    assert shortlist("ppo") == TOP_K
    assert shortlist("ppo", modules=MIXED_TYPES) == TOP_K  # the default model on three types


def own_top_k(tmp_path, value):
    """A copy of the default model whose config.json names ``top_k`` ``value``."""
    for name in ("model.zip", "model_actor.npz", "config.json"):
        shutil.copy(DEFAULT_MODEL.with_name(name), tmp_path / name)
    config = json.loads((tmp_path / "config.json").read_text())
    (tmp_path / "config.json").write_text(json.dumps({**config, "top_k": value}))
    return tmp_path / "model.zip"


def test_a_config_json_may_ask_for_every_child(tmp_path):
    assert shortlist("ppo", own_top_k(tmp_path, None)) is None


@pytest.mark.parametrize("value, words", [(0, "must be >= 1, got 0"),
                                          ("8", "must be an integer")])  # fmt: skip
def test_a_bad_top_k_in_config_json_names_the_file(tmp_path, capsys, value, words):
    model = own_top_k(tmp_path, value)
    where = f"{model.with_name('config.json')}: top_k {words}"
    with pytest.raises(ValueError, match="^" + where.replace(".", r"\.")):
        make_solver("ppo", 7, model=model)
    code = main(["solve", "--method", "ppo", "--model", str(model), "--task",
                 "example:planted_seed1"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and where in err and len(err.strip().splitlines()) == 1
