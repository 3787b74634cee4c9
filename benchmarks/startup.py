"""How fast a user gets a first answer: ``import modquad_gym`` and a small ``modquad solve``.

    python -m benchmarks.startup --runs 15 --out results/startup

Each figure is a whole fresh process (what a user feels), timed over ``--runs`` runs after one
untimed warm-up run (bytecode and numba's on-disk cache warm, as on a user's second run); the
report gives the median and the minimum, the machine's load average while it ran, and which heavy
libraries each process imported. Goals (issue 33): ``import modquad_gym`` <= 0.15 s and
``modquad solve --task example:screwdriver`` <= 0.4 s on a quiet 2-core machine.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time

from benchmarks.common import RawHelpFormatter, bench_args, int_option, run_main, write_text
from modquad_gym.scoring import machine_description

HEAVY = ("numba", "torch", "ray", "mujoco", "scipy", "matplotlib", "gymnasium")

CASES = {
    "import modquad_gym": [sys.executable, "-c", "import modquad_gym"],
    "modquad solve --task example:screwdriver": [
        sys.executable, "-m", "modquad_gym.cli", "solve", "--task", "example:screwdriver",
    ],
    "modquad solve --task example:screwdriver --fault rotor": [
        sys.executable, "-m", "modquad_gym.cli", "solve", "--task", "example:screwdriver",
        "--fault", "rotor",
    ],
}  # fmt: skip
GOALS = {"import modquad_gym": 0.15, "modquad solve --task example:screwdriver": 0.4}

PROBE = (
    "import sys, runpy; sys.argv = {argv!r}; "
    'exec(\'try:\\n    runpy.run_module(sys.argv[0], run_name="__main__")\\n'
    "except SystemExit:\\n    pass') if sys.argv[0] != '-c' else exec(sys.argv[1]); "
    "print('HEAVY', *sorted(m for m in {heavy!r} if m in sys.modules), file=sys.stderr)"
)


def env() -> dict:
    out = dict(os.environ)
    out.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's Python writes bytecode
    return out


def timed(cmd: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env(), check=True, capture_output=True)
    return time.perf_counter() - t0


def heavy_imports(cmd: list[str]) -> list[str]:
    """The heavy libraries a process of ``cmd`` has imported when it ends."""
    argv = cmd[2:] if cmd[1] == "-m" else ["-c", cmd[2]]
    code = PROBE.format(argv=argv, heavy=HEAVY)
    err = subprocess.run([sys.executable, "-c", code], env=env(), capture_output=True, text=True)
    line = next((x for x in err.stderr.splitlines() if x.startswith("HEAVY")), "HEAVY")
    return line.split()[1:]


def main(argv: list[str] | None = None) -> int:
    options = {"--runs": dict(type=int_option(1, 1000), default=15,
                              help="timed runs per case, 1 to 1000 (default 15)")}  # fmt: skip
    args = bench_args(argv, "python -m benchmarks.startup", __doc__, options, seed_help=None,
                      out="results/startup", outputs=("report.md",),
                      formatter_class=RawHelpFormatter)  # fmt: skip
    rows = []
    load0 = os.getloadavg()[0]
    for name, cmd in CASES.items():
        timed(cmd)  # warm-up: bytecode, numba's cache
        seconds = [timed(cmd) for _ in range(args.runs)]
        rows.append((name, statistics.median(seconds), min(seconds), heavy_imports(cmd)))
        print(f"{name}: median {rows[-1][1]:.3f} s", file=sys.stderr)
    load1 = os.getloadavg()[0]
    lines = [
        "# Start-up: the first answer",
        "",
        f"Made by `python -m benchmarks.startup --runs {args.runs} --out {args.out}` on "
        f"{machine_description()}; 1-minute load average {load0:.2f} at the start, "
        f"{load1:.2f} at the end "
        "(2.0 means both cores busy with other work).",
        "",
        "Whole fresh processes, after one warm-up run (bytecode and numba's cache written, as "
        "on a user's second run).",
        "",
        "| command | median (s) | fastest (s) | goal (s) | heavy libraries imported |",
        "|---|---|---|---|---|",
    ]
    for name, median, fastest, heavy in rows:
        goal = GOALS.get(name)
        lines.append(
            f"| `{name}` | {median:.3f} | {fastest:.3f} | {goal if goal else '-'} | "
            f"{', '.join(heavy) or 'none'} |"
        )
    write_text(args.out / "report.md", "\n".join(lines) + "\n")
    print(f"wrote {args.out / 'report.md'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "startup"))
