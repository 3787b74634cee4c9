"""The options of a scoring run that only some methods use, and its tier: one check for both doors.

``model``, ``trust_model`` and ``train_dir`` are the learned methods' alone, ``seed`` is told only
to the methods that draw at random (:func:`takes_seed`), and ``tier`` names one of
:data:`~.tiers.TIERS`: :func:`check_used_options` refuses one that nothing scored would use, for
:func:`~.agents.run_benchmark` in Python's words (``seed=3``, ``trust_model=True``) and for
``modquad score`` (:func:`~.agents.chosen_methods`) in the command line's (``--seed 3``,
``--trust-model``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from modquad_gym.scoring.options import SEEDED
from modquad_gym.scoring.tiers import TIERS
from modquad_gym.search.options import check_seed
from modquad_gym.solvers.factory import draws_at_random

LEARNED = "ppo, ppo-kN, ppo-guided"
"""The learned methods, which alone use ``model``, ``trust_model`` and ``train_dir``."""


def said(option: str, value: Any, flags: bool) -> str:
    """The option as its door writes it: ``--seed 3`` or ``--trust-model`` on the command line
    (``flags``), ``seed=3`` or ``trust_model=True`` in Python."""
    if flags:
        flag = "--" + option.replace("_", "-")
        return flag if value is True else f"{flag} {value}"
    return f"{option}={str(value) if isinstance(value, Path) else value!r}"


def takes_seed(method: str, agents: dict | None = None) -> bool:
    """Is ``method`` told the run's seed: a registered method that draws at random
    (:func:`~modquad_gym.solvers.factory.draws_at_random`: ppo only with sampled rollouts), or
    an outside agent whose constructor takes ``seed`` (``agents``: the outside agents loaded;
    one not among them, or None before they are, is offered the seed, which
    :func:`~modquad_gym.solvers.outside.load_solver` passes only to a constructor that takes
    it). The scoring's solvers and the check of the seed both ask here."""
    if ":" not in method:
        return draws_at_random(method)
    return agents is None or method not in agents or agents[method].takes_seed


def check_used_options(
    methods: list[str],
    *,
    model: Any = None,
    trust_model: bool = False,
    seed: int | None = None,
    tier: str | None = None,
    train_dir: Path | None = None,
    agents: dict | None = None,
    flags: bool = False,
) -> None:
    """A ValueError, in the words of the door (``flags``: the command line's, else Python's),
    for an option given to a scoring run of ``methods`` that none of them uses: ``model``,
    ``trust_model`` or ``train_dir`` with no learned method, a ``seed`` (None: not given)
    with no method that draws at random (``agents``: the outside agents loaded), and for a
    ``tier`` that is none of :data:`~.tiers.TIERS` or a seed out of range."""
    if tier is not None and tier not in TIERS:
        raise ValueError(f"{said('tier', tier, flags)}: unknown tier; choose one of "
                         f"{', '.join(TIERS)}")  # fmt: skip
    learned = any(m.startswith("ppo") for m in methods)
    for option, value in (("model", model), ("train_dir", train_dir),
                          ("trust_model", True if trust_model else None)):  # fmt: skip
        if value is not None and not learned:
            raise ValueError(f"{said(option, value, flags)}: not used: no learned method "
                             f"({LEARNED}) is scored")  # fmt: skip
    if seed is None:
        return
    check_seed(seed, "--seed" if flags else "seed")
    if not any(takes_seed(m, agents) for m in methods):
        raise ValueError(
            f"{said('seed', seed, flags)}: no method scored takes a seed (none draws at "
            f"random); the ones that do: {SEEDED}"
        )
