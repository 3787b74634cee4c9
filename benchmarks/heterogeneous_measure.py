"""Heterogeneous-modules benchmark, the measurements: task sets, certified minima with a palette
and with each type alone, the worst case, MuJoCo validation and the per-workload summary.

Run through :mod:`benchmarks.heterogeneous` (``python -m benchmarks.heterogeneous``), which
describes the experiment; the report text and figure are :mod:`.heterogeneous_report`.
"""

from __future__ import annotations

import time

import numpy as np

from modquad_gym.geometry.module import STOCK_TYPES, palette
from modquad_gym.geometry.polyominoes import A001168
from modquad_gym.geometry.structure import Structure
from modquad_gym.search import exhaustive_search
from modquad_gym.tasks import PaperTasks, PlantedMixedTasks, TaskRequirement

PALETTE = ("t45", "t45m", "flat")
PAIR = ("t45", "t45m")
EXTERNAL_F_MAX = 2.0
GOALS = {2: 2.0, 3: 20.0}
"""Seconds allowed for a certified 2-type and 3-type search to n_max = 7 (the issue)."""


def planted_mixed(rng: np.random.Generator, kind: str, f_max: float) -> TaskRequirement:
    """A task planted in a random mixed structure of 3-6 palette modules (40 wrenches; an
    ``external`` task has the structure's weight subtracted): :class:`PlantedMixedTasks`."""
    gen = PlantedMixedTasks(",".join(PALETTE), kind=kind, f_max=f_max, name=f"planted-{kind}")
    return gen(rng)


def task_sets(n_tasks: int, seed: int) -> dict[str, list[TaskRequirement]]:
    rng = np.random.default_rng(seed)
    paper = PaperTasks(n_wrenches=40)
    ext = PaperTasks(
        n_wrenches=40, kind="external", f_max=EXTERNAL_F_MAX, fz_offset=1.0, fz_gain=8.0
    )
    return {
        "paper": [paper(rng) for _ in range(n_tasks)],
        "paper external": [ext(rng) for _ in range(n_tasks)],
        "planted": [planted_mixed(rng, "total", 1.0) for _ in range(n_tasks)],
        "planted external": [
            planted_mixed(rng, "external", EXTERNAL_F_MAX) for _ in range(n_tasks)
        ],
    }


def _search(task: TaskRequirement, names: tuple[str, ...], n_max: int) -> dict:
    t0 = time.perf_counter()
    r = exhaustive_search(task, n_max=n_max, modules=palette(",".join(names)))
    seconds = time.perf_counter() - t0
    return {
        "n": r.n_modules,
        "evaluated": r.evaluated,
        "skipped": r.skipped,
        "seconds": seconds,
        "structure": r.structure,
    }


def compare(sets: dict[str, list[TaskRequirement]], n_max: int) -> list[dict]:
    """One row per task: the certified minimum with each palette and each type alone."""
    rows = []
    for workload, tasks in sets.items():
        for i, task in enumerate(tasks):
            runs = {names: _search(task, names, n_max) for names in (PALETTE, PAIR)}
            for name in PALETTE:
                runs[(name,)] = _search(task, (name,), n_max)
            alone = [runs[(name,)]["n"] for name in PALETTE]
            best_alone = min((n for n in alone if n is not None), default=None)
            mixed = runs[PALETTE]
            row = {
                "workload": workload,
                "task": i,
                "kind": task.kind,
                "f_max": task.f_max,
                **{f"n_{name}": _n(runs[(name,)]["n"]) for name in PALETTE},
                "n_best_alone": _n(best_alone),
                "n_pair": _n(runs[PAIR]["n"]),
                "n_mixed": _n(mixed["n"]),
                "saved": _saved(best_alone, mixed["n"], n_max),
                "mixed_types": ""
                if mixed["structure"] is None
                else " ".join(m.name for m in mixed["structure"].modules),
                "mixed_cells": ""
                if mixed["structure"] is None
                else " ".join(f"{x},{y}" for x, y in mixed["structure"].cells),
                "evaluated_t45": runs[("t45",)]["evaluated"],
                "evaluated_pair": runs[PAIR]["evaluated"],
                "evaluated_mixed": mixed["evaluated"],
                "skipped_mixed": mixed["skipped"],
                "seconds_t45": round(runs[("t45",)]["seconds"], 4),
                "seconds_pair": round(runs[PAIR]["seconds"], 4),
                "seconds_mixed": round(mixed["seconds"], 4),
            }
            rows.append(row)
            print({k: row[k] for k in ("workload", "task", "n_best_alone", "n_mixed")}, flush=True)
    return rows


def _n(n: int | None) -> int | str:
    return "none" if n is None else n


def _saved(best_alone: int | None, mixed: int | None, n_max: int) -> int | str:
    """Modules saved by mixing; ``>k`` when no single type works up to n_max (k a lower bound:
    a single type needs at least n_max + 1)."""
    if mixed is None:
        return 0 if best_alone is None else "error"
    if best_alone is None:
        return f">={n_max + 1 - mixed}"
    return best_alone - mixed


def refuting_task(seed: int, n_max: int) -> np.ndarray:
    """Low forces, torques of a large hidden T-module structure: no structure of up to
    ``n_max`` modules of the palette satisfies it, and the force bounds skip no level."""
    from benchmarks.search import low_force_task, random_structure

    rng = np.random.default_rng(seed)
    while True:
        W = low_force_task(random_structure(3 * n_max, rng), 8, rng)
        if exhaustive_search(W, n_max=n_max, modules=palette(",".join(PALETTE))).structure is None:
            return W


def worst_case(seed: int, n_max: int) -> list[dict]:
    """The refuting task with 1, 2 and 3 types: every level decided."""
    W = refuting_task(seed, n_max)
    rows = []
    for names in (("t45",), PAIR, PALETTE):
        K = len(names)
        pairs = sum(A001168[n - 1] * K**n for n in range(1, n_max + 1))
        best = None
        for _ in range(3):  # best of three (a shared machine)
            t0 = time.perf_counter()
            r = exhaustive_search(W, n_max=n_max, modules=palette(",".join(names)))
            seconds = time.perf_counter() - t0
            best = seconds if best is None else min(best, seconds)
        rows.append(
            {
                "types": ",".join(names),
                "n_max": n_max,
                "pairs": pairs,
                "skipped_by_bounds": r.skipped,
                "evaluated": r.evaluated,
                "oracle_calls": r.oracle_calls,
                "seconds": round(best, 3),
                "goal_s": GOALS.get(K, ""),
                "found": r.structure is not None,
            }
        )
        print(rows[-1], flush=True)
    return rows


def mujoco_rows(rows: list[dict], sets: dict[str, list[TaskRequirement]], k: int) -> list[dict]:
    """Validate up to ``k`` mixed optima of external tasks in MuJoCo (5 hover wrenches each),
    each a different multiset of types."""
    from modquad_gym.sim import validate

    out, seen = [], set()
    external = [r for r in rows if r["kind"] == "external" and r["mixed_types"]]
    external.sort(key=lambda r: (r["task"], r["workload"]))  # alternate the two task sets
    for row in external:
        types = row["mixed_types"].split()
        mix = tuple(sorted(types))
        if len(out) >= k or len(set(types)) < 2 or mix in seen:  # distinct mixes only
            continue
        seen.add(mix)
        task = sets[row["workload"]][row["task"]]
        cells = [tuple(map(int, c.split(","))) for c in row["mixed_cells"].split()]
        s = Structure(cells, modules=[STOCK_TYPES[t] for t in types])
        rep = validate(
            s, task.wrenches, f_max=task.f_max, kind="external", max_hover_wrenches=5,
            hover_seconds=2.0, render=False,
        ).to_dict()  # fmt: skip
        out.append(
            {
                "workload": row["workload"],
                "task": row["task"],
                "modules": " ".join(types),
                "mass_kg": round(rep["mass_kg"], 3),
                "bench_max_error": rep["bench_max_error"],
                "hover_max_position_error_m": rep["hover_max_position_error_m"],
                "hover_unknown_load_max_position_error_m": rep[
                    "hover_unknown_load_max_position_error_m"
                ],
            }
        )
        print(out[-1], flush=True)
    return out


def summary(rows: list[dict], n_max: int) -> list[dict]:
    """Per workload: how often and by how much the palette saves modules, and search cost."""
    out = []
    for workload in dict.fromkeys(r["workload"] for r in rows):
        rs = [r for r in rows if r["workload"] == workload]
        both = [r for r in rs if isinstance(r["saved"], int) and r["n_mixed"] != "none"]
        only_mix = [r for r in rs if isinstance(r["saved"], str) and r["saved"].startswith(">")]
        saved = [r["saved"] for r in both]
        pair_saved = [
            r["n_t45"] - r["n_pair"]
            for r in rs
            if isinstance(r["n_t45"], int) and isinstance(r["n_pair"], int)
        ]
        out.append(
            {
                "workload": workload,
                "kind": rs[0]["kind"],
                "tasks": len(rs),
                "mix_feasible": sum(r["n_mixed"] != "none" for r in rs),
                "best_type_feasible": sum(r["n_best_alone"] != "none" for r in rs),
                "mix_saves": sum(x > 0 for x in saved) + len(only_mix),
                "only_the_mix": len(only_mix),
                "mean_saved": round(float(np.mean(saved)), 2) if saved else 0.0,
                "max_saved": max(saved, default=0),
                "pair_vs_t45_saves": sum(x > 0 for x in pair_saved),
                "mean_n_t45": _mean(r["n_t45"] for r in rs),
                "mean_n_best_type": _mean(r["n_best_alone"] for r in rs),
                "mean_n_mix": _mean(r["n_mixed"] for r in rs),
                "median_s_t45": _median(r["seconds_t45"] for r in rs),
                "median_s_pair": _median(r["seconds_pair"] for r in rs),
                "median_s_mix": _median(r["seconds_mixed"] for r in rs),
                "max_s_mix": max(r["seconds_mixed"] for r in rs),
                "median_eval_t45": _median(r["evaluated_t45"] for r in rs),
                "median_eval_pair": _median(r["evaluated_pair"] for r in rs),
                "median_eval_mix": _median(r["evaluated_mixed"] for r in rs),
            }
        )
    return out


def _mean(values) -> float | str:
    v = [x for x in values if isinstance(x, int)]
    return round(float(np.mean(v)), 2) if v else "n/a"


def _median(values) -> float:
    return round(float(np.median(list(values))), 4)


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("heterogeneous_measure"))
