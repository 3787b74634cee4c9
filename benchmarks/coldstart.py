"""Cold start: what a fresh process pays before its first answer
(``python -m benchmarks.coldstart``).

Each measurement runs in a fresh Python process, ``--repeats`` times (the median is reported):

* ``import modquad_gym``;
* the first numba dispatch of the process (one call of a compiled function whose machine code
  is cached: the polyomino enumeration of a level above
  :data:`~modquad_gym.geometry.polyominoes.PLAIN_UP_TO` cells; numba loads its own runtime once
  per process, whatever the function);
* ``exhaustive_search`` on an 8-module planted task: its first call in the process and a second
  call on the same task (warm);
* ``modquad solve --method ppo`` (the shipped model) as a user runs it, wall clock of the whole
  command; once more under ``python -X importtime``, which says whether it imported torch or
  SB3 (the shipped models act through their NumPy export, ``model_actor.npz``);
* where the ``train`` extra is installed, for comparison, what the PyTorch path costs (training,
  a model without its NumPy export): ``import torch`` and SB3's ``MaskablePPO.load`` of the
  shipped model (the algorithm and its optimizer, whose construction imports torch's compiler).

Run once with an empty numba cache (``NUMBA_CACHE_DIR`` in a temporary folder: the first run
after an install compiles every function it calls) and then with that cache filled (every later
run). Writes ``coldstart.md`` and ``coldstart.csv`` into ``--out``.
"""

from __future__ import annotations

import importlib.util
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import (
    bench_args,
    command_as_run,
    load_average,
    machine_description,
    markdown_table,
    run_main,
    write_csv,
)
from modquad_gym.core.options import int_option
from modquad_gym.core.outputs import write_text
from modquad_gym.geometry.polyominoes import PLAIN_UP_TO
from modquad_gym.search.checker import COMPILED_AFTER, LP_ROTORS

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
from modquad_gym.policy.models import DEFAULT_MODEL
t0 = time.perf_counter()
sb3_contrib.MaskablePPO.load(DEFAULT_MODEL, device="cpu")
print(time.perf_counter() - t0)
"""
PPO_ARGS = ["-m", "modquad_gym.cli", "solve", "--task", "example:screwdriver", "--method", "ppo",
            "--json"]  # fmt: skip
"""``modquad solve --method ppo`` on a shipped example (from any folder: no repository file)."""
HEAVY = ("torch", "stable_baselines3", "sb3_contrib")
"""The training stack: what ``solve --method ppo`` must not need to import."""
NUMBA_CODE = """
import time
from modquad_gym.geometry import polyominoes
t0 = time.perf_counter()
polyominoes.count(polyominoes.PLAIN_UP_TO + 1)  # the first level numba enumerates
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


NUMBA_STATEMENT = (
    "The first numba dispatch of a process (one call of a compiled function, the enumeration "
    f"of the {PLAIN_UP_TO + 1}-cell polyominoes) loads numba's runtime (its typing and lowering "
    "registries, scipy.linalg for BLAS) once per process, whatever the function and even with "
    "its machine code cached. A search pays it only where it first calls compiled code: levels "
    f"above {PLAIN_UP_TO} cells, structures of more than {LP_ROTORS} rotors or more than "
    f"{COMPILED_AFTER:,} wrench tests; a smaller search answers in plain Python and DAQP."
)
"""The report's paragraph on numba (the thresholds of the code, not a measurement)."""


def has_train_extra() -> bool:
    """torch and SB3 installed (the ``train`` extra): the comparison rows can be measured."""
    return all(importlib.util.find_spec(m) is not None for m in ("torch", "sb3_contrib"))


def heavy_imports(env: dict) -> list[str]:
    """The modules of :data:`HEAVY` that ``modquad solve --method ppo`` imports (read from
    ``python -X importtime``, which lists every module a process imports)."""
    cmd = [sys.executable, "-X", "importtime", *PPO_ARGS]
    err = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stderr
    names = {line.rsplit("|", 1)[-1].strip() for line in err.splitlines() if "|" in line}
    return [m for m in HEAVY if m in names]


def measure(env: dict, task: Path) -> dict[str, float]:
    """One round of every measurement (fresh processes)."""
    py = sys.executable
    imp, first, second = printed([py, "-c", SEARCH_CODE.format(path=str(task))], env)
    (numba,) = printed([py, "-c", NUMBA_CODE], env)
    ppo, _ = timed([py, *PPO_ARGS], env)
    row = {
        "import modquad_gym (s)": imp,
        "first numba dispatch (s)": numba,
        "exhaustive first call (s)": first,
        "exhaustive second call (s)": second,
        "modquad solve --method ppo (s)": ppo,
    }
    if has_train_extra():  # what the PyTorch path would cost; solve --method ppo does not take it
        row["for comparison: import torch (s)"] = timed([py, "-c", "import torch"], env)[0]
        (row["for comparison: MaskablePPO.load of the shipped model (s)"],) = printed(
            [py, "-c", LOAD_CODE], env
        )
    return row


def torch_statement(found: list[str]) -> str:
    """What the report says about the training stack in ``solve --method ppo``, as measured:
    ``found`` are the modules of :data:`HEAVY` the command imported (:func:`heavy_imports`)."""
    said = (
        f"imported {', '.join(found)}"
        if found
        else f"imported none of {', '.join(HEAVY)}: the shipped model acts through its NumPy "
        "export (`model_actor.npz`)"
    )
    rows = (
        " The `for comparison` rows are what the PyTorch path (training, a model without its "
        "NumPy export) pays; the command does not take it."
        if has_train_extra()
        else " torch is not installed here: no comparison rows."
    )
    return (
        f"`modquad solve --method ppo`, run once more under `python -X importtime`, {said}.{rows}"
    )


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
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba"), "OMP_NUM_THREADS": "1"}
        task = Path(tmp) / "planted8.json"
        code = TASK_CODE.format(seed=args.seed, path=str(task))
        subprocess.run([sys.executable, "-c", code], env=env, check=True)
        for cache in ("empty (first run after install)", "filled (every later run)"):
            repeats = 1 if "empty" in cache else args.repeats
            rounds = [measure(env, task) for _ in range(repeats)]
            for key in rounds[0]:
                value = statistics.median(r[key] for r in rounds)
                goal = GOALS.get(key) if "filled" in cache else None
                met = "" if goal is None else ("met" if value <= goal else "NOT met")
                rows.append({"numba cache": cache, "measurement": key, "median": round(value, 4),
                             "runs": len(rounds), "goal": goal or "", "": met})  # fmt: skip
        heavy = heavy_imports(env)
    write_csv(rows, args.out / "coldstart.csv")
    load = load_average(", ")
    text = (
        "# Cold start\n\nCommand: "
        f"`{command_as_run('coldstart', argv)}`"
        f"\n\nMachine: {machine_description()}; load average {load} (a shared machine: "
        "compare rows of one run).\n\n"
        + markdown_table(rows)
        + "\n\n"
        + NUMBA_STATEMENT
        + "\n\n"
        + torch_statement(heavy)
        + "\n"
    )
    write_text(args.out / "coldstart.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "coldstart"))
