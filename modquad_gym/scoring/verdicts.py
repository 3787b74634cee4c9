"""What counts as a success of the agent benchmark: an answer rebuilt from its integer cells
on the tier's module types, of at most n_max modules, that the exact oracle verifies on the
scorer's own task (and that survives the tier's ``fault``). :mod:`.agents` judges each answer in
the scoring process with it, :mod:`.recheck` every success again in a fresh process, and the
leaderboard's checks every submitted row."""

from __future__ import annotations

from modquad_gym.search import verified
from modquad_gym.solvers.answers import NotAllowedError, rebuilt

__all__ = [
    "answer_cells",
    "certified",
    "judged",
    "plain_answer",
    "structure_from",
    "structure_of",
    "survives",
]


def certified(meta: dict, fault: str | None) -> bool:
    """Is the task's ``optimum`` certified for this run's ``fault`` (None: intact)?"""
    return meta.get("optimum") is not None and meta.get("optimum_fault") == fault


def plain_answer(structure, types: list, method: str, task: str):
    """``structure`` rebuilt on ``types`` (None stays None, and so does one off the types)."""
    try:
        return None if structure is None else rebuilt(structure, types)
    except NotAllowedError:
        return None
    except (TypeError, ValueError) as err:
        raise ValueError(f"{method}: task {task!r}: its answer is not a structure: {err}") from None


def answer_cells(structure, types: list | None) -> list[list[int]]:
    """The cells a row records: [x, y] each, and on a tier of several types (``types``, its
    palette) the index of each module's type, [x, y, k]."""
    if types is None:
        return [list(c) for c in structure.cells]
    index = {id(m): k for k, m in enumerate(types)}
    return [[x, y, index[id(m)]] for (x, y), m in zip(structure.cells, structure.modules)]


def judged(answer, task, n_max: int, types: list, fault: str | None) -> bool:
    """Is ``answer`` (a plain structure on ``types``, as :func:`plain_answer` or the leaderboard's
    checks build it, or None) a success on ``task``: at most ``n_max`` modules, verified by the
    exact oracle, surviving ``fault``?"""
    ok = answer is not None and answer.n_modules <= n_max and verified(answer, task)
    return ok and (fault is None or survives(answer, task, fault))


def survives(structure, task, fault: str) -> bool:
    """Does ``structure`` still exert every wrench of ``task`` after any single ``fault``?"""
    from modquad_gym.oracle.faults import tolerates

    W = task.rotor_wrenches(structure)
    return bool(tolerates(structure, W, task.f_max, fault).all())


def structure_of(cells: list | None, types: list, typed: bool):
    """The structure a row's ``cells`` describe on ``types`` (``[x, y]`` each, of the first
    type; ``[x, y, k]`` when ``typed``, k the index of its type), or None when they describe
    none."""
    try:
        return structure_from(cells, types, typed)
    except ValueError:
        return None


def structure_from(cells: list, types: list, typed: bool):
    """:func:`structure_of`'s structure, or a ValueError that says what is wrong with
    ``cells`` (the leaderboard's checks name the row)."""
    from modquad_gym.geometry.structure import Structure

    width = 3 if typed else 2
    if not isinstance(cells, list) or not cells:
        raise ValueError("no cells")
    if any(not isinstance(c, list | tuple) or len(c) != width for c in cells):
        raise ValueError(f"each cell is {'x,y,type index' if typed else 'x,y'}")
    if any(type(v) is not int for c in cells for v in c):
        raise ValueError("each coordinate and type index is an integer")
    if typed and any(not 0 <= c[2] < len(types) for c in cells):
        raise ValueError(f"a type index is not one of the {len(types)} types")
    try:
        if typed:
            return Structure([(x, y) for x, y, _ in cells], modules=[types[k] for *_, k in cells])
        return Structure([(x, y) for x, y in cells], module=types[0])
    except (TypeError, ValueError) as err:
        raise ValueError(str(err)) from None
