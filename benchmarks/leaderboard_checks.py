"""What the leaderboard checks in an outside agent's submission before it ranks it: every row's
cells verified again by the exact oracle against the tier's own task, the optimum taken from
the suite, and a name that no committed method has."""

from __future__ import annotations

import math
from pathlib import Path


def refuse_taken(name: str, where: str) -> None:
    """A ValueError when an outside agent's ``name`` is a committed method's (a registered
    method or a variant of one): its rows would be read as that method's."""
    from modquad_gym.methods import method_of

    try:
        method_of(name)
    except ValueError:
        return
    raise ValueError(
        f"{where}: the agent's name {name!r} is a committed method's; give the agent another "
        "`name` attribute"
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
    from modquad_gym.geometry.structure import Structure

    if not text:
        return None
    width = 2 if types is None else 3
    try:
        cells = [[int(v) for v in c.split(",")] for c in text.split(";")]
        if any(len(c) != width for c in cells):
            raise ValueError(f"each cell is {'x,y' if types is None else 'x,y,type index'}")
        if types is None:
            return Structure([tuple(c) for c in cells], module=_one_type()[0])
        if any(not 0 <= c[2] < len(types) for c in cells):
            raise ValueError(f"a type index is not one of the {len(types)} types")
        return Structure([(x, y) for x, y, _ in cells], modules=[types[k] for *_, k in cells])
    except ValueError as err:
        raise ValueError(f"{where}: cells {text!r}: {err}") from None


def _number(r: dict, key: str, where: str, whole: bool) -> float:
    """Column ``key`` of record ``r``: a finite number >= 0 (a whole one for a count)."""
    try:
        v = float(r[key])
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v >= 0 and (v.is_integer() or not whole)):
        what = "a count" if whole else "seconds"
        raise ValueError(f"{where}: {key} {r[key]!r} is not {what} (a number >= 0)")
    return v


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("leaderboard_checks"))
