"""The one registry of solving methods: each registered once, with its options and capabilities.

A :class:`Method` names how to make its solver, a frozen, typed options dataclass (each field
with its one-line help and its check) and what it can do (certify, draw at random, stop at a
time limit, survive a failure, mix module types). ``modquad solve --method`` (its choices, its
help and its refusals), :func:`modquad_gym.solvers.make_solver`, ``modquad score`` and the
docs' method table all read :data:`REGISTRY`; adding a method is one module with its solve
function and one :func:`register` line.

An option a method does not take is refused with a TypeError that names the option and the
method's options; a problem field a method cannot honour (``fault=`` for a method that never
checks failures) with a ValueError that names it and the methods that can. The same messages
reach Python callers and the command line.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

from modquad_gym.core.options import text_parser, text_words
from modquad_gym.policy.models import (
    BUDGET_PER_MODULE,
    EXTRA_FALLBACKS,
    EXTRA_FROM,
    FALLBACK,
    GUIDED_BUDGET,
    LEARNED_CHECKS,
    MODEL_TOP_K,
    QUEUE_MEMORY,
    SCALE_FROM,
    SMALL_EXTRA_FALLBACKS,
    TOP_K,
)
from modquad_gym.search import options as search_options
from modquad_gym.search.options import COMMON_OPTIONS, Relation, broken_relation, takes_none
from modquad_gym.search.problem import (
    DEFAULT_TIME_LIMIT,
    EXACT_MODULES,
    MAX_MODULES,
    PRUNE,
    unknown_option,
)


# ---------------------------------------------------------------------------------- options
@dataclass(frozen=True)
class Options:
    """Base of every method's options: frozen, typed, each field checked when made."""

    relations: ClassVar[tuple[Relation, ...]] = ()
    """Checks of two options together (:func:`~modquad_gym.search.options.broken_relation`)."""

    def __post_init__(self) -> None:
        """Each field checked; None passes only where the option takes it (its type or default
        says so: :func:`~modquad_gym.search.options.takes_none`), else its check refuses it;
        then the options together (:attr:`relations`)."""
        for f in dataclasses.fields(self):
            check = f.metadata.get("check")
            value = getattr(self, f.name)
            if check is not None and not (value is None and takes_none(f.type, f.default)):
                object.__setattr__(self, f.name, check(value, f.name))
        broken = broken_relation(self.relations, self.as_dict())
        if broken is not None:
            raise ValueError(broken[2])

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def help(cls) -> dict[str, str]:
        """Each option's one-line help, with its default."""
        return {
            f.name: f"{f.metadata.get('help', '')} (default {f.default!r})"
            for f in dataclasses.fields(cls)
        }

    @classmethod
    def settable(cls) -> tuple[str, ...]:
        """The options a command line can set (numbers and flags; objects are Python-only)."""
        return tuple(f.name for f in dataclasses.fields(cls) if _parser(f) is not None)

    @classmethod
    def spelled(cls) -> tuple[str, ...]:
        """The options as a command line spells them: a flag of its own (``--seed``), else
        ``--option KEY=...``; the Python-only ones left out."""
        names = cls.names()
        flags = [OWN_FLAGS[n] for n in names if n in OWN_FLAGS]
        return (*flags, *(f"--option {n}=..." for n in cls.settable() if n not in OWN_FLAGS))

    @classmethod
    def parse(cls, method: str, text: str) -> tuple[str, Any]:
        """``KEY=VALUE`` of ``--option`` as (name, typed and checked value); a TypeError names
        an unknown key, a ValueError (``--option TEXT: ...``) a Python-only key or one with a
        flag of its own that ``--option`` cannot write (:func:`python_only`), text without
        ``=``, a value of the wrong type or out of the option's range."""
        key, sep, value = text.partition("=")
        key = key.strip().replace("-", "_")
        by_name = {f.name: f for f in dataclasses.fields(cls)}
        if key and key not in by_name:
            raise TypeError(unknown_option(method, key, cls.spelled()))
        if key in by_name and _parser(by_name[key]) is None:
            raise ValueError(f"--option {text}: {python_only(method, key)}")
        if not sep or not key:
            raise ValueError(
                f"--option {text}: expected KEY=VALUE, e.g. {key or 'KEY'}=VALUE (method "
                f"{method!r} takes: {', '.join(sorted(cls.settable())) or 'no options'})"
            )
        f = by_name[key]
        if value.strip().lower() == "none" and "None" in str(f.type):  # none of it, or refused
            return key, search_options.none_written(key, text)
        try:
            parsed = _parser(f)(value.strip())
        except ValueError:
            words = text_words(f.type, key in search_options.NONE_MEANS)
            raise ValueError(f"--option {text}: {key} takes {words}, got {value!r}") from None
        check = f.metadata.get("check")
        try:  # the range the options dataclass checks, said now with the option
            return key, parsed if check is None or parsed is None else check(parsed, key)
        except ValueError as exc:
            raise ValueError(f"--option {text}: {exc}") from None

    def as_dict(self) -> dict[str, Any]:
        """The fields as keywords (objects kept as they are, not copied)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


OWN_FLAGS = {"model": "--model", "time_limit": "--time-limit", "seed": "--seed",
             "trust_model": "--trust-model"}  # fmt: skip
"""The method options a command line gives with a flag of its own (``--option`` may too, where
it can write the value; never both)."""


def python_only(method: str, key: str) -> str:
    """Why ``--option KEY`` cannot set a Python-only option of ``method``: its flag, or the
    Python door."""
    if key in OWN_FLAGS:
        return f"give {key} of method {method!r} with {OWN_FLAGS[key]}"
    return (
        f"{key} of method {method!r} is an object a command line cannot write: Python only "
        f"(make_solver({method!r}, {key}=...))"
    )


def _parser(f: dataclasses.Field) -> Callable[[str], Any] | None:
    """How a command line writes the field, from its type (None: Python only)."""
    return text_parser(f.type)


def options_of(name: str, entry: Callable):
    """The options dataclass of a search's entry point (:func:`~.search.problem.search_entry`):
    its search's keyword-only parameters with their types and defaults, and ``prune`` where the
    entry takes it, each with the help and check the entry checks it with
    (``entry.option_specs``): one check per option, whichever door it comes through."""
    specs = []
    parameters = list(inspect.signature(entry.solve).parameters.values())
    for p in parameters + ([PRUNE] if entry.prunes else []):
        if p.kind is not p.KEYWORD_ONLY:
            continue
        text, check = entry.option_specs[p.name]
        meta = {"help": text, "check": check}
        specs.append((p.name, p.annotation, field(default=p.default, metadata=meta)))
    title = "".join(part.title() for part in name.replace("-", "_").split("_"))
    return dataclasses.make_dataclass(f"{title}Options", specs, bases=(Options,), frozen=True,
                                      namespace={"relations": entry.relations})  # fmt: skip


def options(name: str, **fields: tuple[Any, str, str, Callable | None]):
    """An options dataclass from ``NAME=(type, default, help, check)`` (for methods whose
    solver is a class made elsewhere, as the learned ones)."""
    specs = [
        (key, kind, field(default=default, metadata={"help": text, "check": check}))
        for key, (kind, default, text, check) in fields.items()
    ]
    title = "".join(part.title() for part in name.replace("-", "_").split("_"))
    return dataclasses.make_dataclass(f"{title}Options", specs, bases=(Options,), frozen=True)


# ---------------------------------------------------------------------------------- methods
@dataclass(frozen=True)
class Method:
    """One way of answering a problem.

    Attributes:
        name: what ``--method`` and :func:`~modquad_gym.solvers.make_solver` call it.
        help: one line for ``--help`` and the docs.
        options: its :class:`Options` dataclass.
        make: ``make(method, options, problem_defaults) -> solver`` (a solver's ``solve``
            takes a :class:`~modquad_gym.search.SearchProblem`), or its ``"module:name"``
            (imported when the first solver is made, as Gymnasium's entry points are).
        certifies: it proves its answers minimal (or the task infeasible) when it finishes.
        seeded: it draws at random (``seed``).
        timed: it stops at ``time_limit``.
        fault: it honours ``fault=`` (every answer survives the failure).
        palette: it designs over several module types (``modules=``).
        extra: the package extra it needs (``train`` for torch and SB3; a learned method needs
            it only for a model without its NumPy actor), or None.
        max_modules: the largest ``n_max`` it takes (refused beyond, when the solver is made).
    """

    name: str
    help: str
    options: type[Options]
    make: Callable[..., Any] | str
    certifies: bool = False
    seeded: bool = False
    timed: bool = True
    fault: bool = True
    palette: bool = True
    extra: str | None = None
    max_modules: int = MAX_MODULES

    def solver(self, settings: Options, defaults: dict) -> Any:
        """A solver of this method with these checked options and problem defaults."""
        make = self.make
        if isinstance(make, str):
            module, _, name = make.partition(":")
            make = getattr(importlib.import_module(module), name)
        return make(self, settings, defaults)

    def settings(self, **values: Any) -> Options:
        """The options ``values`` checked (TypeError for one the method does not take)."""
        unknown = sorted(set(values) - set(self.options.names()))
        if unknown:
            raise TypeError(unknown_option(self.name, unknown[0], self.options.names()))
        return self.options(**values)

    def check(self, problem: Any) -> None:
        """ValueError (the one message of Python and the CLI) for a problem field this method
        cannot honour."""
        if problem.fault is not None and not self.fault:
            raise ValueError(refused_fault(self.name, problem.fault))
        if problem.typed and len(problem.palette) > 1 and not self.palette:
            raise ValueError(f"method {self.name!r} designs with one module type; modules= gave "
                             f"{len(problem.palette)}")  # fmt: skip


def refused_fault(method: str, fault: str) -> str:
    honour = ", ".join(m.name for m in REGISTRY.values() if m.fault)
    return (
        f"method {method!r} cannot honour fault={fault!r} (it never checks failures); the "
        f"methods that do: {honour}"
    )


REGISTRY: dict[str, Method] = {}
"""Every method by name, in the order ``--help`` lists them."""


def register(method: Method) -> Method:
    """Add ``method`` (a name already taken: ValueError)."""
    if method.name in REGISTRY:
        raise ValueError(f"method {method.name!r} is already registered")
    if ":" in method.name or not method.name:
        raise ValueError(f"method name {method.name!r}: no colon (those name outside agents)")
    REGISTRY[method.name] = method
    return method


def unregister(name: str) -> None:
    """Remove the method ``name`` (for tests and plug-ins that replace one)."""
    REGISTRY.pop(name, None)


# ------------------------------------------------------------------------------- the built-in
def _search(name: str, help: str, **capabilities: Any) -> Method:
    from modquad_gym.search import SEARCHES

    return Method(name, help, options_of(name, SEARCHES[name]),
                  "modquad_gym.solvers.factory:SearchSolver", **capabilities)  # fmt: skip


_MODEL = (object, None, "a PPO .zip or a loaded Policy (default: the shipped model of the "
          "budget and palette)", LEARNED_CHECKS["model"])  # fmt: skip
_TRUST = (bool, False, "load a model .zip that only unpickling reads (a model .zip holds "
          "pickled Python objects that run code when loaded: only a file you trust)",
          LEARNED_CHECKS["trust_model"])  # fmt: skip
_LEARNED_LIMIT = (float | None, DEFAULT_TIME_LIMIT, "seconds after which it stops (None: none)",
                  LEARNED_CHECKS["time_limit"])  # fmt: skip
_TOP_K = (int | None, MODEL_TOP_K, "children decided exactly per step by a model reading the "
          "exact lookahead, the rest (ranked lower by support bounds) masked out (None: all; "
          f"default 'model': its config.json's top_k, else {TOP_K})",
          LEARNED_CHECKS["top_k"])  # fmt: skip
_PRUNE = (bool, False, *COMMON_OPTIONS["prune"])
_FALLBACK = (float | None, None, "dock greedy's choice (ppo-guided: in its dives) wherever the "
             "policy gives its own most likely docking at most this probability (0: never, 1: "
             f"always; None: {FALLBACK:g} at budgets of {SCALE_FROM} modules and more with a "
             "model that sees greedy's choice, the exact lookahead, else 0; none is refused)",
             LEARNED_CHECKS["fallback"])  # fmt: skip
_EXTRA_FALLBACKS = (tuple[float, ...] | None, None, "more deterministic passes, one per fallback "
                    "(comma-separated), branching off where they dock elsewhere; the smallest "
                    "verified structure is kept (None, with a model that sees greedy's choice: "
                    f"{','.join(f'{v:g}' for v in SMALL_EXTRA_FALLBACKS)} below {SCALE_FROM} "
                    f"modules, {','.join(f'{v:g}' for v in EXTRA_FALLBACKS)} where the first "
                    f"ends above {EXTRA_FROM}; else none; empty, or none: the single pass)",
                    LEARNED_CHECKS["extra_fallbacks"])  # fmt: skip
_BUDGET = (int | None, None, "most structures evaluated (None: "
           f"{GUIDED_BUDGET} below {SCALE_FROM} modules, else {BUDGET_PER_MODULE} per module "
           f"of its dives' answer, at least {GUIDED_BUDGET}, at most what "
           f"{QUEUE_MEMORY // 2**20} MiB of queued states hold; none is refused)",
           LEARNED_CHECKS["budget"])  # fmt: skip

for _method in (
    _search("exhaustive", "the certified minimum (exhaustive search, up to 16 modules)",
            certifies=True, timed=False, max_modules=EXACT_MODULES),
    _search("centrosymmetric", "the paper's Algorithm 2"),
    _search("greedy", "baseline: the child satisfying most wrenches"),
    _search("random", "baseline: random dockings", seeded=True),
    _search("anytime", "the default: the exhaustive search's answer where it finishes within "
            "the time limit, else the best structure found by local moves with its proved lower "
            "bound (up to 128 modules)", certifies=True, seeded=True),
    _search("beam", "heuristic: beam search over growing structures (up to 128 modules)",
            seeded=True),
    _search("genetic", "heuristic: genetic algorithm over structures, after Su et al. 2024 (up "
            "to 128 modules)", seeded=True),
    _search("milp", "the mixed-integer program solved by HiGHS, level by level from its LP "
            "relaxation's bound: certified where it finishes within the time limit (up to 128 "
            "modules)", certifies=True, fault=False),
    Method("ppo", f"the learned agent's deterministic pass and two more from its start (below "
           f"{SCALE_FROM} modules, or ending above {EXTRA_FROM}; the shipped model unless model=)",
           options("ppo", model=_MODEL, trust_model=_TRUST,
                   seed=(int, 0, COMMON_OPTIONS["seed"][0], LEARNED_CHECKS["seed"]),
                   samples=(int, 0, "extra sampled rollouts besides the deterministic one",
                            LEARNED_CHECKS["samples"]), time_limit=_LEARNED_LIMIT, top_k=_TOP_K,
                   fallback=_FALLBACK, extra_fallbacks=_EXTRA_FALLBACKS, prune=_PRUNE),
           "modquad_gym.solvers.factory:LearnedSolver", seeded=True, extra="train"),
    Method("ppo-guided", "best-first search ordered by the learned policy, certified where "
           "its answer meets the lower bound",
           options("ppo-guided", model=_MODEL, trust_model=_TRUST, budget=_BUDGET,
                                  branching=(int, 4, "children expanded per node",
                                             LEARNED_CHECKS["branching"]),
                                  dive=(bool, True, "first follow ppo's episodes (with "
                                        "its extra fallbacks' branches; from "
                                        f"{SCALE_FROM} modules one per start type)",
                                        LEARNED_CHECKS["dive"]), time_limit=_LEARNED_LIMIT,
                                  top_k=_TOP_K, fallback=_FALLBACK, prune=_PRUNE),
           "modquad_gym.solvers.factory:LearnedSolver", extra="train"),
):  # fmt: skip
    register(_method)


def method_of(name: str) -> tuple[Method, dict[str, Any]]:
    """The registered method of ``name`` and the options its variant sets: ``ppo-kN`` (N
    sampled rollouts) and ``ppo-guided[-bN][-wN][-nodive]`` (budget, branching, no dive).
    ValueError for an unknown name, naming the known ones."""
    if name in REGISTRY:
        return REGISTRY[name], {}
    if name.startswith("ppo-k") and "ppo" in REGISTRY:
        k = name[len("ppo-k") :]
        if not _digits(k):
            raise ValueError(f"bad method {name!r}; write ppo-kN with N an integer")
        return REGISTRY["ppo"], {"samples": int(k)}
    if name.startswith("ppo-guided-") and "ppo-guided" in REGISTRY:
        return REGISTRY["ppo-guided"], _guided_variant(name)
    raise ValueError(f"unknown method {name!r}; choose one of {', '.join(REGISTRY)}")


def _digits(text: str) -> bool:
    """Whether ``text`` is a count in ASCII digits (``str.isdigit`` also takes ``²`` and
    ``١٢``, which ``int`` then refuses or reads: the command line's numbers are ASCII)."""
    return text.isascii() and text.isdigit()


def _guided_variant(name: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for part in name[len("ppo-guided") :].split("-")[1:]:
        if part == "nodive":
            key, value = "dive", False
        elif part[:1] in ("b", "w") and _digits(part[1:]) and int(part[1:]) > 0:
            key, value = ("budget" if part[0] == "b" else "branching"), int(part[1:])
        else:
            raise ValueError(
                f"bad method {name!r}: write ppo-guided with -bN (budget), -wN (branching) or "
                "-nodive, N a positive integer"
            )
        if key in out:  # which one was meant cannot be told
            raise ValueError(f"bad method {name!r}: it gives the {key} twice; give it once")
        out[key] = value
    return out


def table() -> str:
    """The methods as a Markdown table (the docs' method table is generated from it)."""
    rows = ["| method | what it does | options | certifies | seeded | time limit | fault= |",
            "|---|---|---|---|---|---|---|"]  # fmt: skip
    mark = {True: "yes", False: "no"}
    for m in REGISTRY.values():
        opts = ", ".join(f"`{o}`" for o in m.options.names()) or "none"
        rows.append(
            f"| `{m.name}` | {m.help} | {opts} | {mark[m.certifies]} | {mark[m.seeded]} | "
            f"{mark[m.timed]} | {mark[m.fault]} |"
        )
    return "\n".join(rows)
