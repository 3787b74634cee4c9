"""Given derivatives against the splines of the samples: how far the motions' exact derivatives
are from the splines, in multiples of the splines' estimated error, and how far a motion written
with its times in milliseconds is.

    python -m benchmarks.derivative_agreement [--draws 400] [--wide 1000]

Prints, per population, the largest ``(|given - spline| - accuracy) / estimate`` over the
samples and the given fields (velocity, acceleration, body rates, angular acceleration; the
estimate and the check as :func:`modquad_gym.dynamics.splines.check_given` makes them), which a
:class:`~modquad_gym.dynamics.Trajectory` refuses above
:data:`~modquad_gym.dynamics.splines.AGREEMENT`:

* **grid**: every motion of ``modquad task motion`` over a grid of its options (line: distance
  0.01, 2, 100 m x peak acceleration 0.01, 2, 50 m/s^2; circle and figure-eight: size 0.05, 1,
  50 m x speed 0.1, 1, 5 m/s x laps 0.25, 1, 3, the circle with both headings; push: distance
  0.01, 2, 50 m x speed 0.05, 0.5, 5 m/s x force 0.1, 2 N; hover: 0.01, 2, 100 s) at 4, 10, 100
  and 1,000 samples/s, those the motions build (a ramp too long for the path is refused by
  them); a motion whose samples are too sparse to show it is refused (counted, with the fewest
  samples per turn of the path among them);
* **draws**: ``MotionTasks`` (the dynamic tier's source) under seeds 0 .. draws - 1;
* **suite**: the 60 tasks of ``modquad_gym/data/suites/dynamic_motions.json``;
* **wide**: motions of options log-uniform over wide ranges (:func:`wide`), with those refused
  as too sparse and their samples per turn of the path;
* **milliseconds**: each motion's defaults at 10 and 100 samples/s and 20 draws with their
  times multiplied by 1,000 (the smallest value: every one must be refused).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from benchmarks.common import HelpFormatter, run_main
from modquad_gym import dynamics as dy
from modquad_gym.core.options import OneLineParser, int_option
from modquad_gym.dynamics import quaternions as quat
from modquad_gym.dynamics.splines import AGREEMENT, estimated_error, spline
from modquad_gym.dynamics.trajectory import DEFAULT_ACCURACY

RATES = (4.0, 10.0, 100.0, 1000.0)
GRID = {
    "line": {"distance": (0.01, 2.0, 100.0), "max_acceleration": (0.01, 2.0, 50.0)},
    "circle": {"radius": (0.05, 1.0, 50.0), "speed": (0.1, 1.0, 5.0), "laps": (0.25, 1.0, 3.0),
               "heading": ("fixed", "tangent")},
    "figure_eight": {"size": (0.05, 1.0, 50.0), "speed": (0.1, 1.0, 5.0), "laps": (0.25, 1.0, 3.0)},
    "push": {"distance": (0.01, 2.0, 50.0), "speed": (0.05, 0.5, 5.0), "force": (0.1, 2.0)},
    "hover": {"duration": (0.01, 2.0, 100.0)},
}  # fmt: skip


def excess(data: dict) -> float:
    """The largest ``(|given - spline| - accuracy) / estimate`` of a trajectory dict's given
    derivatives (0 where they agree within accuracy; inf where the estimate is 0)."""
    t, p = np.asarray(data["t"], float), np.asarray(data["position"], float)
    fits = [(p, spline(t, p, None), 1.0, lambda y: y, ("velocity", "acceleration"))]
    if "quaternion" in data:
        q = quat.continuous(np.asarray(data["quaternion"], float))
        qc = quat.conjugate(q)

        def rates(y, qc=qc):
            return 2.0 * quat.multiply(qc, y)[:, 1:]

        angular = ("angular_velocity", "angular_acceleration")
        fits.append((q, spline(t, q, None), 2.0, rates, angular))
    worst = 0.0
    for y, fit, scale, implied_of, fields in fits:
        for order, field in enumerate(fields, 1):
            if field not in data:
                continue
            err = estimated_error(t, y, fit(t, order), order, None)
            if err is None:
                continue
            d = np.abs(np.asarray(data[field], float) - implied_of(fit(t, order))).max()
            over = d - DEFAULT_ACCURACY
            if over > 0:
                worst = max(worst, over / (scale * err) if err > 0 else math.inf)
    return worst


def samples_per_turn(kind: str, args: dict, rate: float) -> float:
    """Samples per radian of path angle at cruise, times 2 pi (inf for straight motions)."""
    if kind == "circle":
        return 2 * math.pi * rate * args["radius"] / args["speed"]
    if kind == "figure_eight":
        return 2 * math.pi * rate * args["size"] * math.sqrt(2.0) / args["speed"]
    return math.inf


def grid() -> tuple[float, float, int, int, float]:
    """(largest excess, largest excess with 2 or more samples per turn, motions built, refused
    as too sparse, fewest samples per turn among those)."""
    worst = worst_resolved = 0.0
    built, sparse, fewest = 0, 0, math.inf
    for kind, options in GRID.items():
        for values in itertools.product(*options.values()):
            for rate in RATES:
                args = dict(zip(options, values))
                try:
                    task = getattr(dy, kind)(**args, rate=rate, f_max=1e9)
                except ValueError as exc:
                    if "too sparse" in str(exc):
                        sparse += 1
                        fewest = min(fewest, samples_per_turn(kind, args, rate))
                    continue
                built += 1
                x = excess(task.trajectory.to_dict())
                worst = max(worst, x)
                if samples_per_turn(kind, args, rate) >= 2:
                    worst_resolved = max(worst_resolved, x)
    return worst, worst_resolved, built, sparse, fewest


def _wide_motion(rng: np.random.Generator) -> tuple[str, dict, float]:
    """(kind, options, rate) log-uniform over wide ranges (:func:`wide`)."""

    def lu(a: float, b: float) -> float:
        return float(np.exp(rng.uniform(np.log(a), np.log(b))))

    kind, rate = str(rng.choice(["line", "circle", "figure_eight", "push"])), lu(4, 2000)
    if kind == "line":
        return kind, {"distance": lu(1e-3, 1e3), "max_acceleration": lu(1e-3, 1e3)}, rate
    if kind == "push":
        return kind, {"distance": lu(1e-3, 1e3), "speed": lu(1e-3, 1e2), "force": 1.0}, rate
    size = "radius" if kind == "circle" else "size"
    args = {size: lu(1e-3, 1e3), "speed": lu(1e-2, 1e3), "laps": lu(0.05, 2000)}
    if kind == "circle":
        args["heading"] = str(rng.choice(["fixed", "tangent"]))
    return kind, args, rate


def wide(n: int) -> tuple[float, int, float, float]:
    """(largest excess, refused as too sparse, fewest and most samples per turn among those)
    over ``n`` motions of options log-uniform over wide ranges (seed 0): rate 4 to 2,000
    samples/s, sizes 1 mm to 1 km, speeds 0.01 to 1,000 m/s, up to 2,000 laps; those a motion
    builds, of at most 20,000 samples."""
    rng = np.random.default_rng(0)
    worst, turns, done = 0.0, [], 0
    while done < n:
        kind, args, rate = _wide_motion(rng)
        try:
            task = getattr(dy, kind)(**args, rate=rate, f_max=1e9)
        except ValueError as exc:
            if "too sparse" in str(exc):
                done += 1
                turns.append(samples_per_turn(kind, args, rate))
            continue
        if task.n_wrenches <= 20_000:
            done += 1
            worst = max(worst, excess(task.trajectory.to_dict()))
    return worst, len(turns), min(turns, default=math.inf), max(turns, default=math.inf)


def milliseconds() -> float:
    """The smallest excess of the motions written with t in milliseconds (hovers left out:
    they have nothing to disagree with)."""
    from modquad_gym.dynamics.random_motions import MotionTasks

    tasks = [f(rate=r) for k, f in dy.MOTIONS.items() if k != "hover" for r in (10.0, 100.0)]
    tasks += [MotionTasks()(np.random.default_rng(s)) for s in range(20)]
    least = math.inf
    for task in tasks:
        if task.trajectory.position.any():
            data = task.trajectory.to_dict()
            data["t"] = [1000.0 * x for x in data["t"]]
            least = min(least, excess(data))
    return least


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(
        prog="python -m benchmarks.derivative_agreement",
        description=__doc__.split("\n\n")[0],
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--draws", type=int_option(1), default=400,
                        help="MotionTasks draws (default 400)")  # fmt: skip
    parser.add_argument("--wide", type=int_option(1), default=1000,
                        help="wide-range motions (default 1000)")  # fmt: skip
    args = parser.parse_args(argv)
    from modquad_gym.dynamics.random_motions import MotionTasks
    from modquad_gym.scoring.suites import SUITES_DIR
    from modquad_gym.tasks import load_suite

    suite = load_suite(SUITES_DIR / "dynamic_motions.json")  # the package's, from any folder
    worst, resolved, built, sparse, fewest = grid()
    draws = max(excess(MotionTasks()(np.random.default_rng(s)).trajectory.to_dict())
                for s in range(args.draws))  # fmt: skip
    held = max(excess(task.trajectory.to_dict()) for task in suite)
    print(f"refused above {AGREEMENT:g} x the estimate (beyond accuracy {DEFAULT_ACCURACY:g})")
    refused = f"{sparse} refused as too sparse ({fewest:.3g} samples per turn or more)"
    print(f"grid: {built} motions, largest {worst:.3g}; with >= 2 samples per turn {resolved:.3g}; "
          f"{refused if sparse else 'none refused as too sparse'}")  # fmt: skip
    print(f"draws: {args.draws}, largest {draws:.3g}")
    print(f"suite: {len(suite)} tasks, largest {held:.3g}")
    worst, sparse, few, many = wide(args.wide)
    print(f"wide: {args.wide} motions, largest accepted {worst:.3g}; {sparse} refused as too "
          f"sparse ({few:.3g} to {many:.3g} samples per turn)")  # fmt: skip
    print(f"milliseconds: smallest {milliseconds():.3g}")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "derivative_agreement"))
