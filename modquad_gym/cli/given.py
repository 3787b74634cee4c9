"""Which options the user typed, and the refusal of those a command would ignore.

An option's value alone cannot tell ``--n-max 7`` from the default 7, so :func:`typed_options`
parses the command line a second time with every default suppressed: what is left is what the
user typed (abbreviations such as ``--payl`` included). :func:`refuse_ignored` turns an option
that does not apply (a search option beside ``--cells``, ``--seed`` for a method that draws
nothing at random, ...) into one error line naming it, instead of a run that silently drops it.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable

TYPED = "typed_options"
"""The attribute of the parsed arguments that holds the typed options' destinations."""


def _parsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """``parser`` and every subcommand parser below it."""
    out = [parser]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in dict.fromkeys(action.choices.values()):
                out += _parsers(sub)
    return out


def typed_options(parser: argparse.ArgumentParser, argv: list[str]) -> frozenset[str]:
    """The destinations of the options present in ``argv`` (which ``parser`` has parsed
    without error): a second parse in which no default fills in what was not typed."""
    actions = [a for p in _parsers(parser) for a in p._actions]
    saved = [a.default for a in actions]
    try:
        for a in actions:
            a.default = argparse.SUPPRESS
        return frozenset(vars(parser.parse_args(argv)))
    finally:
        for a, default in zip(actions, saved):
            a.default = default


def typed(args: argparse.Namespace, dest: str) -> bool:
    """Whether the option of destination ``dest`` was typed (False when the arguments were not
    parsed by :func:`modquad_gym.cli.main`, as in tests calling a command directly)."""
    return dest in getattr(args, TYPED, ())


def option_name(dest: str) -> str:
    return "--" + dest.replace("_", "-")


def refuse_ignored(args: argparse.Namespace, dests: Iterable[str], reason: str) -> None:
    """A ValueError ``--OPTION ...: REASON`` for the first of ``dests`` that was typed."""
    for dest in dests:
        if typed(args, dest):
            value = getattr(args, dest)
            if isinstance(value, (list, tuple)):  # a repeated option: its values as typed
                value = " ".join(map(str, value))
            if isinstance(value, float):  # --time-limit 5, not 5.0
                value = f"{value:g}"
            shown = "" if isinstance(value, bool) else f" {value}"  # a flag has no value
            raise ValueError(f"{option_name(dest)}{shown}: {reason}")


SEARCH_OPTIONS = ("method", "n_max", "time_limit", "model", "trust_model", "seed", "option",
                  "fault", "fault_margin")  # fmt: skip
"""The options that say how a structure is searched for (meaningless beside ``--cells``)."""


def refuse_ignored_method_options(args: argparse.Namespace) -> None:
    """``--seed``, ``--time-limit``, ``--model`` or ``--trust-model`` typed for a method that
    does not take it
    (its registered options, :mod:`modquad_gym.methods`): refused before the search starts."""
    from modquad_gym.methods import method_of

    method = getattr(args, "method", None)
    if method is None:
        return
    entry, _ = method_of(method)
    takes = entry.options.names()
    listed = ", ".join(entry.options.spelled()) or "no options"  # as this door spells them
    for dest in ("seed", "time_limit", "model", "trust_model"):
        if dest not in takes:
            refuse_ignored(args, [dest], f"method {method!r} does not take it (it takes: {listed})")


def refuse_budget(args: argparse.Namespace) -> None:
    """``--n-max`` beyond the method's reach (16 modules for exhaustive, else 128), refused
    before any file is read, naming the option (make_solver's check, in this door's words)."""
    from modquad_gym.methods import method_of
    from modquad_gym.solvers.factory import beyond_reach

    method, n_max = getattr(args, "method", None), getattr(args, "n_max", None)
    if method is None or not isinstance(n_max, int):
        return
    refusal = beyond_reach(method_of(method)[0], n_max, "--n-max")
    if refusal is not None:
        raise ValueError(refusal)


def refuse_conflicting_options(args, options, values: dict, said: dict[str, str]) -> None:
    """The method's options a command line gave (``values``, each checked alone; ``said``: each
    one's ``--option`` text) checked together (``options.relations``) and against the flags, a
    ValueError naming the ``--option`` of one that breaks a relation (``--option elite=30:
    elite must be <= 23 ...``) or contradicts a flag (``progress=true`` with ``--quiet``)."""
    import dataclasses

    from modquad_gym.search.options import broken_relation

    if values.get("progress") and getattr(args, "quiet", False):
        raise ValueError(f"--option {said['progress']}: contradicts --quiet (no progress on "
                         "stderr); give one or the other")  # fmt: skip
    defaults = {f.name: f.default for f in dataclasses.fields(options)}
    broken = broken_relation(options.relations, defaults | values)
    if broken is not None:
        name, bound, message = broken
        raise ValueError(f"--option {said.get(name) or said[bound]}: {message}")


def refuse_ignored_csv_header(args: argparse.Namespace) -> None:
    """``--csv-header`` when no task file of ``--task`` is a CSV file (it says how a CSV file's
    first row reads; JSON and .npy files have none): refused before any file is read. A
    ``--task`` that cannot be listed is left to the command, which names what is wrong."""
    specs = getattr(args, "task", None)
    if not typed(args, "csv_header") or specs is None:
        return
    from pathlib import Path

    from modquad_gym.tasks import task_files
    from modquad_gym.tasks.examples import resolve_task_path

    try:
        paths = [
            resolve_task_path(p) for p in task_files([specs] if isinstance(specs, str) else specs)
        ]
    except (ValueError, OSError):
        return
    if not any(Path(p).suffix.lower() == ".csv" for p in paths):
        refuse_ignored(args, ["csv_header"], "applies to CSV task files; --task gives none")
