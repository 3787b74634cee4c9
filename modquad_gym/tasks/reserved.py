"""The seeds reserved for the benchmark's own tasks, and the warning an environment gives when it
is seeded with one.

Every validation and held-out task is drawn from ``numpy.random.default_rng(seed)`` with a seed
of these ranges (:mod:`modquad_gym.scoring.suites`, :mod:`~modquad_gym.scoring.tiers`,
:mod:`~modquad_gym.scoring.scale_tasks`), and an environment seeded by ``reset(seed=s)`` draws
its first task from the same generator: ``reset(seed=s)`` with a held-out seed gives that
held-out task, its planted answer in ``env.unwrapped.task.meta``. So no agent may reset an
environment, draw a task or train with a seed of these ranges:

* :data:`VALIDATION_SEEDS`: 500,000-999,999, the validation tasks training selects its model on
  (``VALIDATION_SEED0 + i``);
* :data:`HELDOUT_SEEDS`: 1,000,000-8,999,999, the held-out suites of every tier (planted
  1,000,000, paper 2,000,000, large 3,000,000, mixed 4,000,000, scale 5,000,000, dynamic
  7,000,000, fault 8,000,000 and up) and the scale suites' validation draws (6,000,000 and up).

A seed sequence ``default_rng([seed, k])`` with k > 0 (how the training code draws its
demonstration and focus tasks) is, to numpy, the integer ``seed + k * 2**32`` (or one of more
words for a larger seed): never one of these.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from numbers import Integral

VALIDATION_SEEDS = range(500_000, 1_000_000)
"""Seeds of the validation tasks (:func:`modquad_gym.scoring.suites.validation_tasks`)."""
HELDOUT_SEEDS = range(1_000_000, 9_000_000)
"""Seeds of the held-out suites (and the scale suites' validation draws)."""
RESERVED_SEEDS = {"validation": VALIDATION_SEEDS, "held-out": HELDOUT_SEEDS}
"""Every reserved range by what it holds."""


class ReservedSeedWarning(UserWarning):
    """An environment was seeded with a validation or held-out seed."""


_QUIET: ContextVar[bool] = ContextVar("modquad_gym_reserved_seeds_quiet", default=False)


def reserved_range(seed: object) -> str | None:
    """``"validation"`` or ``"held-out"`` when ``seed`` (an integer) is reserved, else None."""
    if isinstance(seed, bool) or not isinstance(seed, Integral):
        return None
    return next((what for what, seeds in RESERVED_SEEDS.items() if int(seed) in seeds), None)


def span(seeds: range) -> str:
    """A range of seeds in words: ``1,000,000-8,999,999`` (one seed: ``999,999``)."""
    last = seeds.stop - 1
    return f"{seeds.start:,}" if last == seeds.start else f"{seeds.start:,}-{last:,}"


def reserved_met(seeds: range) -> list[str]:
    """The reserved ranges (by what they hold) that ``seeds``, consecutive integers, meet."""
    return [what for what, reserved in RESERVED_SEEDS.items()
            if max(seeds.start, reserved.start) < min(seeds.stop, reserved.stop)]  # fmt: skip


@contextmanager
def reserved_draws() -> Iterator[None]:
    """Within it, :func:`warn_reserved` is silent in this thread (and its context): the path for
    the project's own code that seeds an environment with a number it does not choose (the
    group sampler's random seed) or draws a reserved task on purpose. Not a warnings filter:
    an agent's own resets elsewhere still warn."""
    token = _QUIET.set(True)
    try:
        yield
    finally:
        _QUIET.reset(token)


def warn_reserved(owner: object, seed: object) -> None:
    """Warn once per ``owner`` (an environment) that ``seed`` is reserved
    (:class:`ReservedSeedWarning`, a UserWarning), unless inside :func:`reserved_draws`."""
    what = reserved_range(seed)
    if what is None or _QUIET.get() or getattr(owner, "_warned_reserved_seed", False):
        return
    try:
        owner._warned_reserved_seed = True  # type: ignore[attr-defined]
    except AttributeError:
        pass
    warnings.warn(
        f"reset(seed={seed}): seeds {span(RESERVED_SEEDS[what])} are reserved for the "
        f"benchmark's {what} tasks, and this environment's draws can reproduce one (with its "
        f"planted answer in task.meta); never reset, draw tasks or train with seeds "
        f"{span(VALIDATION_SEEDS)} or {span(HELDOUT_SEEDS)} (docs/leaderboard.md)",
        ReservedSeedWarning,
        stacklevel=3,
    )
