"""Cold start: what a fresh process pays before its first answer
(``python -m benchmarks.coldstart``).

Each measurement runs in a fresh Python process, ``--repeats`` times (the median is reported):

* ``import modquad_gym``;
* the first numba dispatch of the process (one call of a compiled function whose machine code
  is cached: numba loads its own runtime once per process, whatever the function);
* ``exhaustive_search`` on an 8-module planted task: its first call in the process and a second
  call on the same task (warm);
* ``modquad solve --method ppo`` (the shipped model) as a user runs it, wall clock of the whole
  command, beside ``import torch`` alone (its floor), and loading the shipped model (torch and
  SB3 imported) as SB3 does (``MaskablePPO.load``: the algorithm and its optimizer, whose
  construction imports torch's compiler) and as inference does (the policy network only).

Run once with an empty numba cache (``NUMBA_CACHE_DIR`` in a temporary folder: the first run
after an install compiles every function it calls) and then with that cache filled (every later
run). Writes ``coldstart.md`` and ``coldstart.csv`` into ``--out``.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import (
    bench_args,
    load_average,
    machine_description,
    markdown_table,
    run_main,
    write_csv,
)
from modquad_gym.core.options import int_option
from modquad_gym.core.outputs import write_text

GOALS = {"exhaustive first call (s)": 0.05, "modquad solve --method ppo (s)": 3.0}
"""Issue 23's goals after the first run following install (a filled numba cache)."""

TASK_CODE = (
    "import numpy as np; from modquad_gym.tasks import PlantedTasks; "
    "PlantedTasks(n_modules=8, n_wrenches=20)(np.random.default_rng({seed})).save({path!r})"
)
SEARCH_CODE = """
import time
t0 = time.perf_counter()
import modquad_gym as mq
t1 = time.perf_counter()
task = mq.TaskRequirement.load({path!r})
t2 = time.perf_counter()
first = mq.exhaustive_search(task, n_max=8)
t3 = time.perf_counter()
mq.exhaustive_search(task, n_max=8)
t4 = time.perf_counter()
print(t1 - t0, t3 - t2, t4 - t3)
"""
LOAD_CODE = """
import time
import torch, sb3_contrib
from modquad_gym.policy.models import DEFAULT_MODEL, load_model
t0 = time.perf_counter()
if {full}:
    sb3_contrib.MaskablePPO.load(DEFAULT_MODEL, device="cpu")
else:
    load_model(DEFAULT_MODEL)
print(time.perf_counter() - t0)
"""
NUMBA_CODE = """
import time
from modquad_gym.geometry import polyominoes
t0 = time.perf_counter()
polyominoes.count(1)
print(time.perf_counter() - t0)
"""


def timed(cmd: list[str], env: dict) -> tuple[float, str]:
    """(wall seconds of ``cmd`` in a fresh process, what it printed)."""
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    return time.perf_counter() - t0, out.stdout


def printed(cmd: list[str], env: dict) -> list[float]:
    """The numbers ``cmd`` printed (its own timings)."""
    return [float(x) for x in timed(cmd, env)[1].split()]


def measure(env: dict, task: Path, root: Path) -> dict[str, float]:
    """One round of every measurement (fresh processes)."""
    py = sys.executable
    imp, first, second = printed([py, "-c", SEARCH_CODE.format(path=str(task))], env)
    (numba,) = printed([py, "-c", NUMBA_CODE], env)
    ppo, _ = timed([py, "-m", "modquad_gym.cli", "solve", "--task",
                    str(root / "examples" / "screwdriver.json"), "--method", "ppo", "--json"],
                   env)  # fmt: skip
    torch, _ = timed([py, "-c", "import torch"], env)
    (full,) = printed([py, "-c", LOAD_CODE.format(full=True)], env)
    (net,) = printed([py, "-c", LOAD_CODE.format(full=False)], env)
    return {
        "import modquad_gym (s)": imp,
        "first numba dispatch (s)": numba,
        "exhaustive first call (s)": first,
        "exhaustive second call (s)": second,
        "modquad solve --method ppo (s)": ppo,
        "import torch (s)": torch,
        "load the shipped model: MaskablePPO.load (s)": full,
        "load the shipped model: policy network only (s)": net,
    }


def main(argv: list[str] | None = None) -> int:
    args = bench_args(
        argv,
        "python -m benchmarks.coldstart",
        "Time a fresh process's first answers: import, the first exhaustive search, the first "
        "`modquad solve --method ppo`; with an empty and with a filled numba cache.",
        {"--repeats": {"type": int_option(1, 100), "default": 3,
                       "help": "fresh processes per measurement (the median is reported)"}},
        outputs=("coldstart.md", "coldstart.csv"),
    )  # fmt: skip
    root = Path(__file__).resolve().parents[2]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba"), "OMP_NUM_THREADS": "1"}
        task = Path(tmp) / "planted8.json"
        code = TASK_CODE.format(seed=args.seed, path=str(task))
        subprocess.run([sys.executable, "-c", code], env=env, check=True)
        for cache in ("empty (first run after install)", "filled (every later run)"):
            repeats = 1 if "empty" in cache else args.repeats
            rounds = [measure(env, task, root) for _ in range(repeats)]
            for key in rounds[0]:
                value = statistics.median(r[key] for r in rounds)
                goal = GOALS.get(key) if "filled" in cache else None
                met = "" if goal is None else ("met" if value <= goal else "NOT met")
                rows.append({"numba cache": cache, "measurement": key, "median": round(value, 4),
                             "runs": len(rounds), "goal": goal or "", "": met})  # fmt: skip
    write_csv(rows, args.out / "coldstart.csv")
    load = load_average(", ")
    text = (
        "# Cold start\n\nCommand: "
        f"`python -m benchmarks.coldstart {' '.join(argv or sys.argv[1:])}`"
        f"\n\nMachine: {machine_description()}; load average {load} (a shared machine: "
        "compare rows of one run).\n\n" + markdown_table(rows) + "\n\n"
        "The first numba dispatch of a process loads numba's runtime (its typing and lowering "
        "registries, scipy.linalg for BLAS) once per process, whatever the function and even "
        "with its machine code cached; every compiled function on the way to an answer pays "
        "it, so an exhaustive search's first call costs at least that row. "
        "`modquad solve --method ppo` costs at least `import torch`.\n"
    )
    write_text(args.out / "coldstart.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "coldstart"))
