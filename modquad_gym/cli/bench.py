"""``modquad bench WHAT``: run one of the benchmarks (each writes its report under results/)."""

from __future__ import annotations

import argparse
import importlib

from modquad_gym.cli.common import add_command

BENCHMARKS = {
    "oracle": ("modquad_gym.bench.oracle", "feasibility methods compared"),
    "search": ("modquad_gym.bench.search", "exhaustive search vs an LP reference"),
    "scaling": (
        "modquad_gym.bench.scaling",
        "the exhaustive search level by level up to 14 modules",
    ),
    "anytime": (
        "modquad_gym.bench.anytime",
        "the default anytime search on planted 16-64-module tasks; --reach: exact to 16",
    ),
    "scale": (
        "modquad_gym.bench.scale",
        "every method (anytime, baselines, learned) on the held-out 16-64-module suites",
    ),
    "level-bounds": ("modquad_gym.bench.level_bounds", "regenerate the shipped level bounds"),
    "distributed": (
        "modquad_gym.bench.distributed",
        "a batch and a large search serially and on Ray with 1 and 2 CPUs",
    ),
    "heterogeneous": (
        "modquad_gym.bench.heterogeneous",
        "mixing module types and self-weight against one type",
    ),
    "env": ("modquad_gym.bench.env", "environment steps/s"),
    "paper": ("modquad_gym.bench.paper", "the paper's Sec. VI experiment"),
    "agents": ("modquad_gym.bench.agents", "PPO vs the searches on held-out tasks"),
    "coldstart": ("modquad_gym.bench.coldstart", "a fresh process's first search and PPO answer"),
    "dynamics": (
        "modquad_gym.bench.dynamics",
        "minimum structures for motions (circle, figure-eight, push), flown in MuJoCo",
    ),
}
"""Benchmark name -> (module with ``main(argv)``, what it measures): the choices and help of
``bench``."""


def add_bench(sub) -> None:
    p = add_command(
        sub,
        "bench",
        cmd_bench,
        help="run a benchmark (writes results/)",
        description="Run a benchmark; options after the name go to it "
        "(e.g. `modquad bench oracle --help`).",
    )
    p.add_argument(
        "what",
        choices=tuple(BENCHMARKS),
        help="; ".join(f"{name}: {what}" for name, (_, what) in BENCHMARKS.items()),
    )
    p.add_argument(
        "rest",
        nargs=argparse.REMAINDER,
        metavar="OPTIONS",
        help="options passed on to the benchmark (see `modquad bench WHAT --help`)",
    )


def cmd_bench(args: argparse.Namespace) -> int:
    from modquad_gym.bench import run_as

    module, _ = BENCHMARKS[args.what]
    with run_as(f"modquad bench {args.what}"):  # its usage and errors name what the user typed
        importlib.import_module(module).main(args.rest)
    return 0
