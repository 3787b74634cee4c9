"""The one check of each search option, shared by every door.

A search's entry point (:func:`~.problem.search_entry`) checks every keyword option it is given
with the check named here (the search's own, else :data:`COMMON_OPTIONS`); the options
dataclasses of :mod:`modquad_gym.methods`, which :func:`~modquad_gym.solvers.make_solver` and
``modquad solve --option`` read, take the same checks from the entry point. So
``random_search(..., restarts=0)``, ``make_solver("random", restarts=0)`` and ``--option
restarts=0`` are refused with the same words. A check is ``check(value, name) -> value``
(the value as the search uses it) or a ValueError naming ``name`` and the value. None is "not
set" for an option whose type admits it (``int | None``) or whose default is None: the entry
point then uses the default (``seed=None`` is seed :data:`DEFAULT_SEED` in every door, never fresh
entropy); for any other option None is checked, and refused, like any value of the wrong type.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import numpy as np

from modquad_gym.core.options import MAX_SEED
from modquad_gym.core.resources import GIB, check_memory
from modquad_gym.core.validation import check_flag, check_int, check_real
from modquad_gym.search.partial import check_start

Check = Callable[[Any, str], Any]
"""``check(value, name) -> value``: the value as the search uses it, or a ValueError."""

MAX_TIME_LIMIT = 86_400.0
"""The longest time limit accepted: one day."""

PRUNE_HELP = "then drop modules the answer does not need, one at a time (within the time limit)"
"""The one-line help of the ``prune`` option, wherever a method takes it."""


def check_time_limit(seconds: object, name: str = "time_limit") -> float:
    """``seconds`` as a float in (0, :data:`MAX_TIME_LIMIT`], else a one-line ValueError naming
    ``name`` (a string or a bool is not a number of seconds)."""
    value = check_real(seconds, name)
    if not 0.0 < value <= MAX_TIME_LIMIT:
        raise ValueError(f"{name} must lie in (0, {MAX_TIME_LIMIT:,.0f}] seconds, got {seconds!r}")
    return value


CHUNK_BYTES = 512
"""Bytes one structure of a ``chunk`` takes at most while its batch is decided: 252 B at 14
modules (tracemalloc's peak over a chunk of 262,144 drawn and decided by the checker; about 18 B
per module), so 512 B covers the 16 modules of the exhaustive levels with room."""

MAX_CHUNK = 2**20
"""The largest ``chunk`` (64 times the default): at most :data:`CHUNK_BYTES` x 2**20 = 0.5 GiB
per batch."""


def check_chunk(value: Any, name: str = "chunk") -> int:
    """The check of ``chunk``: an integer in 1..:data:`MAX_CHUNK` whose batch fits the memory
    available here (:func:`~modquad_gym.core.resources.check_memory`), else a one-line
    ValueError naming ``name`` and the value, before anything is allocated."""
    chunk = check_int(value, name, low=1, high=MAX_CHUNK)
    check_memory(chunk * CHUNK_BYTES, f"{name}={chunk}")
    return chunk


def count(low: int, high: int | None = None) -> Check:
    """The check of an integer count in [low, high]."""
    return lambda value, name: check_int(value, name, low=low, high=high)


def share(value: Any, name: str) -> float:
    """The check of a probability or fraction in [0, 1]."""
    return check_real(value, name, 0.0, 1.0)


def shares(value: Any, name: str) -> tuple[float, ...]:
    """The check of one share or a sequence of them (a tuple)."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        value = (value,)
    return tuple(share(v, name) for v in value)


def check_seed(value: Any, name: str) -> int:
    """The check of a random seed: an integer in 0..2**63-1, as ``--seed`` takes."""
    return check_int(value, name, low=0, high=MAX_SEED)


DEFAULT_SEED = 0
"""The seed of a search that draws at random when none is given (None included)."""


def seeded_rng(seed: Any) -> np.random.Generator:
    """The random generator of a search's ``seed``: None is :data:`DEFAULT_SEED`, so a call
    without a seed gives the same answer every time and in every door (make_solver's, the
    command line's)."""
    return np.random.default_rng(DEFAULT_SEED if seed is None else check_seed(seed, "seed"))


def takes_none(annotation: Any, default: Any) -> bool:
    """Whether None is "not set" for an option of this type and default: its type admits None
    (``int | None``) or its default is None. Any other option refuses None by its check."""
    return default is None or re.search(r"\bNone\b", str(annotation)) is not None


NONE_MEANS: dict[str, Any] = {"time_limit": None, "top_k": None, "extra_fallbacks": ()}
"""What ``none`` on a command line (``--option KEY=none``) gives, by option: none of it (no
time limit, no shortlist: every child, no extra passes: the same as ``extra_fallbacks=``).
Every other option refuses ``none`` (:func:`none_written`): its None only stands for its
default (``fallback``, ``budget``, ``seed``, ``penalty``), which leaving the option out gives,
while ``none`` would read as "never" or "no budget"."""

NONE_HELP = (
    "VALUE none means none of it (top_k=none: every child, no shortlist; extra_fallbacks=none: "
    "no extra pass, as extra_fallbacks=) and is refused where it would stand for the default "
    "(fallback, budget, seed, penalty: leave the option out)"
)
""":data:`NONE_MEANS` in words, for ``--option``'s help."""


def none_written(key: str, text: str) -> Any:
    """The value of ``--option TEXT`` whose value is ``none`` (:data:`NONE_MEANS`), or a
    ValueError naming ``TEXT`` for an option whose None only stands for its default."""
    if key in NONE_MEANS:
        return NONE_MEANS[key]
    raise ValueError(f"--option {text}: {key} takes no none (its None only stands for its "
                     f"default, which leaving {key} out gives)")  # fmt: skip


def check_engine(value: Any, name: str) -> Any:
    """An engine that splits work (``first(fn, items, accept)``, as
    :class:`~modquad_gym.core.distributed.Engine` has), else a ValueError."""
    if not callable(getattr(value, "first", None)):
        raise ValueError(
            f"{name} must be an Engine (modquad_gym.core.distributed.Engine), got {value!r}"
        )
    return value


def check_producers(value: Any, name: str) -> tuple:
    """A sequence of producers (search entries or callables, :mod:`.portfolio`) as a tuple,
    else a ValueError naming the first that is not one."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise ValueError(
            f"{name} must be a sequence of producers (search functions or callables), got {value!r}"
        )
    out = tuple(value)
    for i, producer in enumerate(out):
        if not callable(producer):
            raise ValueError(f"{name}[{i}] must be a search function or callable, got {producer!r}")
    return out


def non_negative(value: Any, name: str) -> float:
    """The check of a finite real number >= 0."""
    return check_real(value, name, low=0.0)


COMMON_OPTIONS: dict[str, tuple[str, Check | None]] = {
    "time_limit": ("seconds the method may take; it returns what it has by then", check_time_limit),
    "seed": ("seed of its random draws (0 to 2**63-1)", check_seed),
    "progress": ("show progress on stderr", check_flag),
    "engine": ("an Engine whose workers share the work (Python only)", check_engine),
    "chunk": (
        f"structures decided per batch, 1 to {MAX_CHUNK:,} (about {CHUNK_BYTES} B each: "
        f"{MAX_CHUNK * CHUNK_BYTES / GIB:g} GiB at most, refused beyond the memory available)",
        check_chunk,
    ),
    "start": ("a partial structure every answer contains (Python only)", check_start),
    "producers": (
        "the producers run beside the anytime search's own steps (Python only)",
        check_producers,
    ),  # fmt: skip
    "prune": (PRUNE_HELP, check_flag),
}
"""Help and check of the options several searches share (``start``'s size and module types
are checked against the problem's by the search, :func:`~.partial.make_partial`, and by
:func:`~modquad_gym.solvers.make_solver` against the ``n_max`` and ``modules`` it is given)."""


Relation = tuple[str, str, int]
"""``(option, bound, offset)``: ``option`` may be at most ``bound`` + ``offset`` (genetic's
``("elite", "population", -1)``): a check of two options together."""


def broken_relation(relations: tuple[Relation, ...], values: dict) -> tuple[str, str, str] | None:
    """(option, the option bounding it, the one-line message) of the first of ``relations``
    that ``values`` (every option, given or default) break; None when they hold."""
    for name, bound, offset in relations:
        high = values[bound] + offset
        if values[name] > high:
            sign = f" {'+' if offset > 0 else '-'} {abs(offset)}" if offset else ""
            said = f"{bound} {values[bound]}{sign}"
            return name, bound, f"{name} must be <= {high} ({said}), got {values[name]}"
    return None


def option_specs(
    search: str, names: list[str], own: dict[str, tuple[str, Check | None]] | None
) -> dict[str, tuple[str, Check | None]]:
    """The (help, check) of each option ``names`` of ``search``: its ``own``, else the
    common one (a name in neither: a programming error, said at import)."""
    own = own or {}
    missing = [n for n in names if n not in own and n not in COMMON_OPTIONS]
    if missing:
        raise KeyError(f"search {search!r}: option {missing[0]!r} has no help and check")
    return {n: own.get(n) or COMMON_OPTIONS[n] for n in names}


def checked_options(
    specs: dict[str, tuple[str, Check | None]], values: dict, defaults: dict[str, tuple]
) -> dict:
    """``values`` with each option checked by its spec; ``defaults`` holds each option's
    (annotation, default): None for an option that takes it (:func:`takes_none`) becomes the
    default, for any other it is checked (and refused) as any value."""
    out = dict(values)
    for key, value in values.items():
        check = specs[key][1]
        if value is None and takes_none(*defaults[key]):
            out[key] = defaults[key][1]
        elif check is not None:
            out[key] = check(value, key)
    return out
