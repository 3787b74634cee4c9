"""Batch work and a large search on Ray: wall time with 1 and 2 local workers, Ray's start-up.

    python -m benchmarks.distributed [--tasks 1000] [--n-max 7] [--search-n-max 13 [14 ...]]
                                     [--seed 0]

Writes ``results/distributed.md`` and ``.csv``. Two workloads, each run serially (no Ray), on an
embedded Ray with 1 CPU and with 2 CPUs, every answer compared with the serial one:

* a batch: the certified optima (every optimal structure,
  :func:`modquad_gym.scoring.optima.optimum_record`,
  the unit of work of ``modquad optima``) of ``--tasks`` training-like tasks (the ``mixed`` task
  source of ``train.py``: planted tasks of 2-6 modules and paper-like tasks);
* for each ``--search-n-max``, one certified exhaustive search on a task that no structure of
  up to that many modules satisfies, so every level is decided to its end (levels of more than
  262,144 structures, 12 modules and up, are split into Ray tasks of 262,144 structures).

Wall times include everything a user waits for until the answers are in: starting Ray, its
worker processes importing the package, the work (not the shutdown after it, which waits for
Ray's processes to exit so that its session folder can be removed); ``startup_s`` is the part
until a no-op task has returned on every CPU. The report ends with the commands that run the same
on a cluster.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.common import (
    Distinct,
    bench_args,
    int_option,
    report_page,
    run_main,
    write_report,
)

MODES = (("serial (no Ray)", 0), ("Ray, 1 CPU", 1), ("Ray, 2 CPUs", 2))
"""(label, Ray CPUs; 0: the serial path of :mod:`modquad_gym.core.distributed`)."""


def _noop(i: int) -> int:
    time.sleep(0.2)  # long enough that each CPU gets one
    return i


def _start_ray(cpus: int):
    """Start an embedded Ray with ``cpus`` CPUs and one worker process per CPU: (seconds taken,
    its session folder)."""
    import ray

    from modquad_gym.core.distributed import map_tasks
    from modquad_gym.core.ray_session import start_local

    t0 = time.perf_counter()
    options = {"include_dashboard": False, "log_to_driver": False, "logging_level": "ERROR"}
    session = start_local(ray, cpus, options)
    map_tasks(_noop, range(max(cpus, 2)), workers=max(cpus, 2))  # on the Ray just started
    return time.perf_counter() - t0, session


def _timed(cpus: int, work) -> tuple[float, float, object]:
    """(wall seconds, start-up seconds, result) of ``work(workers)`` serially (cpus = 0) or on
    an embedded Ray with ``cpus`` CPUs, started inside the timing and shut down after it (the
    shutdown waits for Ray's processes to exit, then removes its session folder unless Ray
    reported an error)."""
    t0 = time.perf_counter()
    if not cpus:
        result = work(1)
        return time.perf_counter() - t0, 0.0, result
    import ray

    from modquad_gym.core.ray_session import shutdown

    startup, session = _start_ray(cpus)
    failed = False
    try:
        result = work(max(cpus, 2))  # > 1 worker: the Ray path, on the Ray just started
        return time.perf_counter() - t0, startup, result
    except ray.exceptions.RayError:
        failed = True  # Ray's message points to its logs: the session folder stays
        raise
    finally:
        shutdown(ray, session, failed)


def batch_tasks(n: int, seed: int) -> list:
    from modquad_gym.tasks import make_generator

    generator = make_generator("mixed")
    rng = np.random.default_rng([seed, 2])
    return [(f"mixed-{seed}-{i}", generator(rng)) for i in range(n)]


def run_batch(tasks: list, n_max: int) -> list[dict]:
    from functools import partial

    from modquad_gym.core.distributed import map_tasks
    from modquad_gym.scoring.optima import optimum_record

    def work(workers: int):
        records = map_tasks(partial(optimum_record, n_max), tasks, workers=workers)
        return [{k: v for k, v in r.items() if k != "seconds"} for r in records]

    rows, reference = [], None
    for label, cpus in MODES:
        wall, startup, records = _timed(cpus, work)
        reference = records if reference is None else reference
        evaluated = sum(r["evaluated"] for r in records)
        rows.append(_row(f"optima of {len(tasks)} tasks (n_max {n_max})", label, wall,
                         startup, records == reference, evaluated))  # fmt: skip
        print(rows[-1], flush=True)
    return rows


def run_search(n_max: int, seed: int) -> list[dict]:
    from benchmarks.scaling import refuting_task
    from modquad_gym.core.distributed import Engine
    from modquad_gym.search import exhaustive_search

    W = refuting_task(seed, n_max)

    def work(workers: int):
        engine = Engine(workers) if workers > 1 else None
        r = exhaustive_search(W, n_max=n_max, engine=engine)
        return r.structure, r.evaluated

    rows, reference = [], None
    for label, cpus in MODES:
        wall, startup, (structure, evaluated) = _timed(cpus, work)
        reference = structure if reference is None else reference
        rows.append(_row(f"exhaustive search, n_max {n_max}, no structure", label, wall,
                         startup, structure == reference, evaluated))  # fmt: skip
        print(rows[-1], flush=True)
    return rows


def _row(workload, mode, wall, startup, same, evaluated) -> dict:
    return {
        "workload": workload,
        "mode": mode,
        "wall_s": round(wall, 2),
        "startup_s": round(startup, 2),
        "work_s": round(wall - startup, 2),
        "evaluated": evaluated,
        "same_answers": "yes" if same else "NO",
    }


def _with_speedups(rows: list[dict]) -> list[dict]:
    out = []
    for r in rows:
        serial = next(s for s in rows if s["workload"] == r["workload"])
        out.append({**r, "speedup_wall": round(serial["wall_s"] / r["wall_s"], 2),
                    "speedup_work": round(serial["work_s"] / r["work_s"], 2)})  # fmt: skip
    return out


CLUSTER = """\
```bash
# every node: the same Python environment with the package and Ray
pip install -r requirements.txt && pip install --no-deps -e .
# Ray >= 2.59 uses token authentication: share one token with every node and driver
export RAY_AUTH_MODE=token
export RAY_AUTH_TOKEN=$(python -c 'import secrets; print(secrets.token_hex(16))')
# head node
ray start --head --port=6379
# each other node (same RAY_AUTH_MODE and RAY_AUTH_TOKEN)
ray start --address=HEAD_IP:6379
# driver (any node): the same commands as on one machine, RAY_ADDRESS picks the cluster
RAY_ADDRESS=HEAD_IP:6379 modquad optima --suite heldout_paper --n-max 7 --out optima.jsonl
RAY_ADDRESS=HEAD_IP:6379 modquad solve --task tasks/ --json > answers.jsonl
RAY_ADDRESS=HEAD_IP:6379 modquad solve --task big_task.json --n-max 15 --workers 64
RAY_ADDRESS=HEAD_IP:6379 python train.py --seeds 0 1 2 3
# when done, on each node
ray stop
```"""


def report(rows: list[dict], args: argparse.Namespace, seconds: float) -> str:
    command = (
        f"python -m benchmarks.distributed --tasks {args.tasks} --n-max {args.n_max} "
        f"--search-n-max {' '.join(map(str, args.search_n_max))} --seed {args.seed}"
    )
    batch = [r for r in rows if r["workload"].startswith("optima")]
    searches: dict[str, list[dict]] = {}
    for r in rows:
        if r["workload"].startswith("exhaustive"):
            searches.setdefault(r["workload"], []).append(r)

    def line(rs):
        two = rs[-1]
        return (f"{two['speedup_wall']:g}x wall ({rs[0]['wall_s']:g} s -> {two['wall_s']:g} s), "
                f"{two['speedup_work']:g}x without Ray's start-up")  # fmt: skip

    startups = [r["startup_s"] for r in rows if r["startup_s"] > 0]
    return report_page(
        "Batch work and a large search on Ray",
        command,
        "Each workload runs three ways: the serial path of "
        "`modquad_gym.core.distributed` (no Ray), "
        "an embedded Ray with 1 CPU, and one with 2 CPUs. `wall_s` is what a user waits for "
        "until the answers are in (Ray's start, its workers importing the package, the work; "
        "not the shutdown after it); `startup_s` "
        "is `ray.init` until a no-op task has returned on every CPU; `work_s` = wall - "
        "start-up. `same_answers`: every record (optimum, all optimal structures, evaluated "
        "counts) or the search's answer equals the serial run's. The batch is the unit of work "
        "of `modquad optima` on training-like tasks (`mixed`: planted tasks of 2-6 modules and "
        "paper-like tasks); each search is a task no structure of up to n_max modules "
        "satisfies, so every structure of every level not ruled out by the exact bounds is "
        "decided (`evaluated`); on Ray, levels of more than 262,144 structures (12 modules and "
        "up) are split into tasks of 262,144 structures, each starting from the separating "
        "directions known before the level (the serial search carries them from one structure "
        "to the next, so a split level costs more CPU time in all; less so the larger the "
        "level); smaller levels are decided in the driver, as serially.",
        rows,
        f"- Batch of {args.tasks} tasks, 2 CPUs vs serial: {line(batch)}.",
        *[f"- {name}, 2 CPUs vs serial: {line(rs)}." for name, rs in searches.items()],
        f"- Ray's start-up on this machine: {min(startups):g}-{max(startups):g} s per start, "
        "paid once per command; batches shorter than a few times that are faster serially, "
        "which is why `--workers 1` (and a batch of one task) never starts Ray.",
        "",
        "## The same on a cluster",
        "",
        "Every command takes `--ray-address HOST:PORT` or reads `RAY_ADDRESS`; with a cluster "
        "and no `--workers`, the tasks go to every CPU of the cluster. Tested here with a "
        "two-node cluster on one host (`tests/test_distributed.py`, "
        "`test_two_node_cluster_on_this_host`).",
        "",
        CLUSTER,
        "",
        how=f", in {seconds:.0f} s",
        caveat=" (above ~1 another job shared the CPUs, so the speed-ups are those of a shared "
        "machine)",
    )  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    options = {
        "--tasks": dict(type=int_option(2), default=1000, help="batch size (default 1000)"),
        "--n-max": dict(type=int_option(1, 16), default=7, help="batch n_max (default 7)"),
        "--search-n-max": dict(type=int_option(11, 16), nargs="+", action=Distinct, default=[13],
                               help="n_max of the searches, one search each (default 13)"),
    }  # fmt: skip
    args = bench_args(
        argv,
        "python -m benchmarks.distributed",
        "Time a batch of certified optima and one large exhaustive search serially and on an "
        "embedded Ray with 1 and 2 CPUs; write results/distributed.{md,csv}.",
        options,
        outputs=("distributed.md", "distributed.csv"),
    )
    from modquad_gym.core.distributed import ray_problem

    if ray_problem() is not None:  # not installed, or its import fails: said in one line
        raise ImportError(ray_problem())
    t0 = time.perf_counter()
    rows = run_batch(batch_tasks(args.tasks, args.seed), args.n_max)
    for n in args.search_n_max:
        rows += run_search(n, args.seed)
    rows = _with_speedups(rows)
    text = report(rows, args, time.perf_counter() - t0)
    write_report(args.out, "distributed", rows, text)
    print(text)


if __name__ == "__main__":
    raise SystemExit(run_main(main, "distributed"))
