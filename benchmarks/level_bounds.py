"""Regenerate the level bounds shipped with the package (the default T-module, 1..14 modules).

    python -m benchmarks.level_bounds [--n-max 14] [--out modquad_gym/data/level_bounds]

One pass over every level (about three minutes for 1..14 on one core); see
:mod:`modquad_gym.search.bounds` for what the bounds are.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import bench_args, int_option, run_main
from modquad_gym.core.outputs import atomic_write
from modquad_gym.search.bounds import compute_level_bounds, module_digest
from modquad_gym.search.problem import DEFAULT_MODULE


def main(argv: list[str] | None = None) -> None:
    options = {
        "--n-max": dict(type=int_option(1, 16), default=14, help="largest level (default 14)"),
    }
    args = bench_args(argv, "python -m benchmarks.level_bounds", __doc__, options, seed_help=None,
                      out="modquad_gym/data/level_bounds", out_help="folder",
                      outputs=(f"{module_digest(DEFAULT_MODULE)}.npz",))  # fmt: skip
    t0 = time.perf_counter()
    arrays = {f"n{n}": compute_level_bounds(DEFAULT_MODULE, n) for n in range(1, args.n_max + 1)}
    path = args.out / f"{module_digest(DEFAULT_MODULE)}.npz"
    atomic_write(path, lambda tmp: np.savez(tmp.open("wb"), **arrays))
    print(f"wrote {path} in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    raise SystemExit(run_main(main, "level_bounds"))
