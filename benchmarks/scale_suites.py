"""Held-out suites at the field's sizes: tasks planted in hidden structures of 16-128 modules.

Four families, each a seeded draw around a hidden random connected structure of ``n`` modules
(``n`` the size band: 16 to 128), so the planted size bounds the optimum from above:

* ``planted``: one module type, 40 wrenches inside the hidden zonotope, half near its boundary
  (:class:`~modquad_gym.tasks.PlantedTasks`): the lift bound is usually close to the optimum;
* ``mixed``: the palette t45, t45m, flat, 40 wrenches of a hidden mixed structure
  (:class:`~modquad_gym.tasks.PlantedMixedTasks`): searches choose shapes and types;
* ``payload``: carrying a heavy payload with the structure's own weight (kind ``external``,
  f_max 2 N): the hidden structure runs its rotors at 70-100 % of f_max, and the wrench on the
  payload is what is left after lifting itself (:func:`payload_task`);
* ``torque``: low force, high torque (:func:`.search.low_force_task`): forces one module can
  exert, torques that need the hidden structure's lever arms. No lift bound helps there.

Seeds: held-out task ``i`` of family ``f`` (index in :data:`FAMILIES`) in band ``n`` is drawn
from ``default_rng(SCALE_SEED0 + 10_000 f + 100 n + i)``; validation tasks (where settings are
tuned) from ``SCALE_VALIDATION_SEED0`` in the same layout. Training never uses either range.

Each task's ``meta`` holds ``seed``, ``family``, ``band``, ``palette`` (stock names, or None for
the T-module), ``planted`` (the hidden size: an upper bound on the optimum), ``lift_bound`` (the
instant bounds: force or count, and the level bounds), and what the default search proved within
``--time-limit`` seconds: ``lower_bound`` (certified: no smaller structure works) and
``best_known`` (the smallest verified structure it found).

``python -m benchmarks.scale_suites`` writes ``scale_N.json`` into ``results/scale_suites``
(deterministic up to the time limit's reach); ``--out modquad_gym/data/suites --force`` replaces
the shipped suites.
"""

from __future__ import annotations

import time
from pathlib import Path

from benchmarks.common import Distinct, HelpFormatter, add_force, hold_out, run_main
from modquad_gym.core.options import OneLineParser, int_option, path_option, real_option
from modquad_gym.core.outputs import OutputError, check_output_file
from modquad_gym.scoring.scale_tasks import (  # noqa: F401 - the suites' families, re-exported
    BANDS,
    FAMILIES,
    MIXED_PALETTE,
    PAYLOAD_F_MAX,
    SCALE_SEED0,
    SCALE_VALIDATION_SEED0,
    draw,
    payload_task,
    task_palette,
    task_seed,
    torque_task,
)
from modquad_gym.scoring.suites import SUITES_DIR
from modquad_gym.search import SearchProblem, anytime_search, bound_levels
from modquad_gym.tasks import (
    TaskRequirement,
    load_suite,
    save_suite,
)


def with_bounds(task: TaskRequirement, time_limit: float) -> TaskRequirement:
    """``task`` with ``lift_bound`` (instant), ``lower_bound`` and ``best_known`` (the default
    search within ``time_limit``) and ``bound_seconds`` in its meta."""
    modules = task_palette(task)
    extra = {"modules": modules} if modules else {}
    n_max = search_budget(task.meta["band"])
    problem = SearchProblem.build(task, n_max, **extra)
    t0 = time.perf_counter()
    r = anytime_search(task, n_max=n_max, time_limit=time_limit, **extra)
    seconds = round(time.perf_counter() - t0, 2)
    meta = {**task.meta, "lift_bound": bound_levels(problem), "lower_bound": r.lower_bound,
            "best_known": r.n_modules, "bound_seconds": seconds}  # fmt: skip
    return TaskRequirement(task.wrenches, name=task.name, f_max=task.f_max, kind=task.kind,
                           meta=meta)  # fmt: skip


def search_budget(band: int) -> int:
    """The module budget the scale tasks of ``band`` are searched with: 64, or the band above."""
    return max(64, band)


def suite_path(band: int, root: Path = SUITES_DIR) -> Path:
    return root / f"scale_{band}.json"


def load_scale_suite(band: int, families=None, per_family: int | None = None) -> list:
    """The shipped held-out tasks of ``band`` (only ``families``, the first ``per_family`` of
    each, when given)."""
    tasks = load_suite(suite_path(band))
    keep = set(families or FAMILIES)
    counts: dict[str, int] = {}
    out = []
    for task in tasks:
        family = task.meta["family"]
        counts[family] = counts.get(family, 0) + 1
        if family in keep and (per_family is None or counts[family] <= per_family):
            out.append(task)
    return out


def build_band(band: int, per_family: int, time_limit: float, validation: bool = False) -> list:
    """``per_family`` tasks of every family in ``band`` with their bounds."""
    tasks = []
    for family in FAMILIES:
        for i in range(per_family):
            tasks.append(with_bounds(draw(family, band, i, validation), time_limit))
            m = tasks[-1].meta
            print(f"{tasks[-1].name}: planted {m['planted']}, lift bound {m['lift_bound']}, "
                  f"lower bound {m['lower_bound']}, best known {m['best_known']} "
                  f"({m['bound_seconds']} s)", flush=True)  # fmt: skip
    return tasks


def main(argv: list[str] | None = None) -> int:
    p = OneLineParser(
        prog="python -m benchmarks.scale_suites",
        formatter_class=HelpFormatter,
        description="Write the held-out scale suites (scale_N.json): fixed seeds, the planted "
        "size and the bounds the default search proves. The shipped suites are replaced only "
        f"when asked: --out {SUITES_DIR.relative_to(SUITES_DIR.parents[2])} --force.",
    )
    p.add_argument("--bands", type=int_option(1, 128), nargs="+", action=Distinct,
                   default=list(BANDS), help="size bands, one suite file each")  # fmt: skip
    p.add_argument("--per-family", type=int_option(1, 100), default=3,
                   help="tasks per family and band")  # fmt: skip
    p.add_argument(
        "--time-limit",
        type=real_option,
        default=10.0,
        help="seconds of the default search per task for the bounds, in (0, 3600] (default 10)",
    )
    p.add_argument(
        "--out",
        type=path_option,
        default=Path("results/scale_suites"),
        help="folder of the suite files (default %(default)s; the shipped ones are in "
        f"{SUITES_DIR.relative_to(SUITES_DIR.parents[2])})",
    )
    add_force(p)
    args = p.parse_args(argv)
    if not 0 < args.time_limit <= 3600:
        p.error(f"--time-limit must lie in (0, 3600] seconds, got {args.time_limit:g}")
    try:  # before any work: never replace a suite (the shipped ones least) unasked; held
        hold_out(args.out, tuple(suite_path(b, Path()).name for b in args.bands),
                 args.force)  # fmt: skip
    except OutputError as exc:
        p.error(str(exc))
    for band in args.bands:  # each once (argparse refuses a band given twice)
        tasks = build_band(band, args.per_family, args.time_limit)
        try:  # again after the work, in the command's words: a file that appeared meanwhile
            path = check_output_file(suite_path(band, args.out), args.force, what="--out")
        except OutputError as exc:
            p.error(str(exc))
        save_suite(tasks, path, name=f"scale_{band}", force=True)
        print(f"{path}: {len(tasks)} tasks")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "scale_suites"))
