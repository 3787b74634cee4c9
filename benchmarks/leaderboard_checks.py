"""What the leaderboard checks in an outside agent's submission before it ranks it: a file with
the columns it reads and known tiers, one row per (seed, suite, task) and the same tasks in every
seed, every row's cells verified again by the exact oracle against the tier's own task, the
optimum taken from the suite, and a name that no committed method has."""

from __future__ import annotations

import csv
import math
import unicodedata
from pathlib import Path

SUBMISSION_COLUMNS = ("tier", "seed", "method", "status", "suite", "task", "success",
                      "n_modules", "evaluated", "oracle_calls", "seconds", "cells")  # fmt: skip
"""The columns of a submission file that the leaderboard reads (its optimum, gap and optimal
come from the suite)."""


def refuse_taken(name: str, where: str) -> None:
    """A ValueError when an outside agent's ``name`` could be read as a committed method's (a
    registered method or a variant of one): the same once NFKC-normalised, case-folded and
    stripped, or followed by a parenthesis (``greedy (2 seeds)``); and a name that holds an
    invisible character (a control, format or separator character other than the space)."""
    from modquad_gym.methods import method_of

    name = str(name)
    plain = unicodedata.normalize("NFKC", unicodedata.normalize("NFKC", name).casefold())
    hidden = [c for c in plain if unicodedata.category(c)[0] in "CZ" and c != " "]
    if hidden or not plain.strip():
        what = f"holds an invisible character U+{ord(hidden[0]):04X}" if hidden else "is empty"
        raise ValueError(f"{where}: the agent's name {name!r} {what}; give the agent a "
                         "visible `name` attribute")  # fmt: skip
    for candidate in (plain.strip(), plain.partition("(")[0].strip()):
        try:
            method_of(candidate)
        except ValueError:
            continue
        read = f" (read as {candidate!r})" if candidate != name else ""
        raise ValueError(
            f"{where}: the agent's name {name!r} is a committed method's{read}; give the agent "
            "another `name` attribute"
        )


def submission_records(path: Path) -> list[tuple[int, dict]]:
    """Each (1-based row, record) of a submission file. A file without a column of
    :data:`SUBMISSION_COLUMNS` (or not a CSV file at all), or a row whose tier is not a
    benchmark tier, is a ValueError naming ``path`` (and the row)."""
    from modquad_gym.scoring.tiers import TIERS

    try:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            have = reader.fieldnames or []
            missing = [c for c in SUBMISSION_COLUMNS if c not in have]
            if missing:
                raise ValueError(f"{path}: not a submission file: no column "
                                 f"{', '.join(missing)}")  # fmt: skip
            numbered = list(enumerate(reader, start=1))
    except (UnicodeDecodeError, csv.Error) as err:
        raise ValueError(f"{path}: not a submission file (a CSV file in UTF-8): {err}") from None
    for n, r in numbered:
        if r["tier"] not in TIERS:
            raise ValueError(f"{path}: row {n} (line {n + 1}): tier {r['tier']!r} is not a "
                             f"benchmark tier; write one of {', '.join(TIERS)}")  # fmt: skip
    return numbered


def one_row_per_task(path: Path, tier: str, method: str, numbered: list[tuple[int, dict]]):
    """A ValueError naming ``path`` unless ``method``'s scored rows on ``tier`` (1-based row,
    record) hold one row per (seed, suite, task), and every seed the same tasks: a task
    repeated, or a seed holding only the tasks it did well on, would count twice or not at
    all."""
    first: dict[tuple, int] = {}
    tasks: dict[str, set] = {}
    for n, r in numbered:
        key = (r["seed"], r["suite"], r["task"])
        if key in first:
            raise ValueError(
                f"{path}: row {n} (line {n + 1}) repeats row {first[key]}: seed {r['seed']!r}, "
                f"task {r['task']!r} of suite {r['suite']!r}; a submission holds one row per "
                "(seed, suite, task)"
            )
        first[key] = n
        tasks.setdefault(r["seed"], set()).add((r["suite"], r["task"]))
    seeds = list(tasks)
    for seed in seeds[1:]:
        a, b = tasks[seeds[0]], tasks[seed]
        if a != b:
            suite, task = min(a ^ b, key=str)
            only = seeds[0] if (suite, task) in a else seed
            raise ValueError(
                f"{path}: seeds {seeds[0]!r} and {seed!r} of {method!r} on tier {tier} cover "
                f"different tasks ({len(a)} and {len(b)}; task {task!r} of suite {suite!r} "
                f"only in seed {only!r}); every seed covers the same tasks"
            )


def verified_rows(path: Path, tier, numbered: list[tuple[int, dict]]) -> list:
    """The :class:`~modquad_gym.scoring.scores.Row` of each (1-based row, record) of a
    submission on ``tier``: its cells verified against the tier's own task (at most n_max
    modules of the tier's types, the exact oracle, the tier's fault), the optimum the suite's.
    A row whose ``success`` or ``n_modules`` disagrees with its cells, a task not in the tier,
    malformed cells or counts, or an answer below the certified optimum is a ValueError naming
    ``path`` and the row."""
    from modquad_gym.geometry.module import palette
    from modquad_gym.scoring.agents import judged
    from modquad_gym.scoring.scores import Row

    tasks = {(s, t.name): t for s, ts in tier.load_suites().items() for t in ts}
    types = palette(tier.modules) if tier.modules else None
    seen: dict[tuple, bool] = {}
    out = []
    for n, r in numbered:
        where = f"{path}: row {n} (line {n + 1})"
        task = tasks.get((r["suite"], r["task"]))
        if task is None:
            raise ValueError(f"{where}: task {r['task']!r} of suite {r['suite']!r} is not one "
                             f"of tier {tier.name}'s held-out tasks")  # fmt: skip
        answer = _answer(r["cells"], types, where)
        key = (r["suite"], r["task"], r["cells"])
        if key not in seen:
            seen[key] = judged(answer, task, tier.n_max, types or _one_type(), tier.fault)
        ok, size = seen[key], None if answer is None else answer.n_modules
        claimed = (r["success"], r["n_modules"])
        if claimed != (("1", str(size)) if ok else ("0", "")):
            raise ValueError(
                f"{where}: success {r['success']!r} and n_modules {r['n_modules']!r} disagree "
                f"with its cells {r['cells']!r}, which are "
                + (f"a verified answer of {size} modules" if ok else "no verified answer")
            )
        optimum = task.meta.get("optimum")
        if ok and optimum is not None and size < optimum:
            raise ValueError(f"{where}: {size} modules verified below the certified optimum "
                             f"{optimum}: the verification was subverted")  # fmt: skip
        counts = [_number(r, k, where, whole) for k, whole in
                  (("evaluated", True), ("oracle_calls", True), ("seconds", False))]  # fmt: skip
        cells = [list(c) for c in answer.cells] if ok else None
        out.append(Row(r["suite"], r["task"], optimum, r["method"], ok, size if ok else None,
                       int(counts[0]), int(counts[1]), counts[2], cells))  # fmt: skip
    return out


def _one_type() -> list:
    from modquad_gym.search.problem import DEFAULT_MODULE

    return [DEFAULT_MODULE]


def _answer(text: str, types: list | None, where: str):
    """The structure a row's ``cells`` write (``x,y`` each, ``x,y,k`` with the index k of its
    type in the tier's palette), None for none; ValueError naming ``where`` otherwise."""
    from modquad_gym.core.options import parse_integer
    from modquad_gym.scoring.verdicts import structure_from

    if not text:
        return None
    try:
        cells = [[parse_integer(v) for v in c.split(",")] for c in text.split(";")]
        return structure_from(cells, types or _one_type(), typed=types is not None)
    except ValueError as err:
        raise ValueError(f"{where}: cells {text!r}: {err}") from None


def _number(r: dict, key: str, where: str, whole: bool) -> float:
    """Column ``key`` of record ``r``: a finite number >= 0 (a whole one for a count)."""
    from modquad_gym.core.options import parse_real

    try:
        v = parse_real(r[key])
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and v >= 0 and (v.is_integer() or not whole)):
        what = "a count" if whole else "seconds"
        raise ValueError(f"{where}: {key} {r[key]!r} is not {what} (a number >= 0)")
    return v


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("leaderboard_checks"))
