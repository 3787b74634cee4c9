"""``modquad task motion``: write a dynamic task file (a motion of :mod:`modquad_gym.dynamics`)."""

from __future__ import annotations

import argparse
import re

from modquad_gym.cli.common import add_command, add_force, f_max_option
from modquad_gym.core.options import nonempty_option, parse_real, real_option
from modquad_gym.dynamics.motions import LongMotionError
from modquad_gym.dynamics.trajectory import MAX_SAMPLES

PARAMETERS = {
    "hover": ("duration",),
    "line": ("distance", "max_acceleration"),
    "circle": ("radius", "speed", "laps", "heading"),
    "figure-eight": ("size", "speed", "laps"),
    "push": ("distance", "speed", "push_force"),
}
"""The motion options each ``--kind`` takes (the others are refused)."""

OPTION_HELP = {
    "duration": "hover: seconds, at least one sample interval (1 / --rate) (default 2)",
    "distance": "line, push: metres along x (default 2)",
    "max_acceleration": "line: peak acceleration, m/s^2 (default 2)",
    "radius": "circle: metres (default 1)",
    "size": "figure-eight: half-width, metres (default 1)",
    "speed": "circle, figure-eight, push: cruise speed, m/s (default 1; push 0.5)",
    "laps": "circle, figure-eight: turns (default 1)",
    "push_force": "push: contact force the structure exerts along the path, N (default 2)",
}


def add_motion(tsub) -> None:
    from modquad_gym.dynamics.motions import MIN_PHASE_INTERVALS

    m = add_command(
        tsub,
        "motion",
        cmd_task_motion,
        help="write a dynamic task file (a trajectory, optional payload)",
        description="Write a dynamic task: a motion (hover, straight line, circle, "
        "figure-eight, push) sampled with closed-form derivatives, holding a payload. Its "
        "wrenches depend on the structure that flies it; `modquad solve` finds the smallest "
        "structure that can, `modquad validate` flies it in MuJoCo.",
    )
    m.add_argument("--kind", choices=tuple(PARAMETERS), required=True, help="the motion")
    for name, text in OPTION_HELP.items():
        flag = "--force-n" if name == "push_force" else "--" + name.replace("_", "-")
        m.add_argument(flag, dest=name, type=real_option, default=None, help=text)
    m.add_argument(
        "--heading",
        choices=("fixed", "tangent"),
        default=None,
        help="circle: keep the heading (fixed, default) or turn with the path (tangent: body +y "
        "along the velocity, +x away from the centre; the structure's inertia enters the "
        "wrenches)",
    )
    m.add_argument(
        "--payload-mass", type=real_option, default=None, help="kg (default 0: no payload)"
    )
    m.add_argument(
        "--payload-offset",
        type=nonempty_option,
        default=None,
        metavar="X,Y,Z",
        help="payload position from the structure's COM, metres (default 0,0,0); needs "
        "--payload-mass",
    )
    m.add_argument(
        "--f-max", type=f_max_option, default=2.0, help="rotor limit, N, up to 1e12 (default 2)"
    )
    m.add_argument(
        "--rate",
        type=real_option,
        default=100.0,
        help="samples/s (default 100); a move or a speed ramp must span at least "
        f"{MIN_PHASE_INTERVALS} sample intervals",
    )
    m.add_argument("--name", default=None, help="task name (default: the kind)")
    m.add_argument("--out", required=True, help="output .json file")
    add_force(m)


OPTION_OF = {
    **{
        name: "--" + name.replace("_", "-")
        for name in (*OPTION_HELP, "heading", "rate", "f_max", "name")
    },
    "push_force": "--force-n",
    "force": "--force-n",
    "exerted": "--force-n",
    "payload.mass": "--payload-mass",
    "payload.offset": "--payload-offset",
}
"""The option of each name the motions' errors start with (``rate: ...``, ``f_max must ...``)."""

NAMED_IN_ADVICE = ("rate", "max_acceleration", "distance")
"""Parameters a motion's error also names in its advice (``raise rate``): said as options."""


PATH_OPTIONS = {"circle": ("radius", "laps"), "figure-eight": ("size", "laps")}
"""The options that set how long each kind's path is (push: ``distance``)."""


def option_message(exc: ValueError, args: argparse.Namespace) -> str:
    """A motion's error as the command line says it: the option in place of the keyword. The
    ramp, which the command line does not set, is named by what makes the path too short for
    its speed: the typed options among ``--speed`` and the path's (all when none is typed)."""
    from modquad_gym.cli.given import typed

    text, kind = str(exc), args.kind
    if text.startswith("ramp:"):
        causes = ["speed", *PATH_OPTIONS.get(kind, ("distance",))]
        blamed = [p for p in causes if typed(args, p)] or causes
        shown = ", ".join(f"{OPTION_OF[p]} {getattr(args, p):g}" if getattr(args, p) is not None
                          else OPTION_OF[p] for p in blamed)  # fmt: skip
        path = " or ".join(OPTION_OF[p] for p in causes[1:])
        return (
            f"{shown}: too fast for this --kind {kind} path: speeding up and slowing down take "
            f"1 s each, longer than the whole path at this speed; lower --speed or lengthen the "
            f"path ({path})"
        )
    match = re.match(r"([a-z_.]+)(:| must)", text)
    if match and match[1] in OPTION_OF:
        rest = re.sub(
            r"\b(" + "|".join(NAMED_IN_ADVICE) + r")\b",
            lambda m: OPTION_OF[m[1]],
            text[len(match[1]) :],
        )
        return OPTION_OF[match[1]] + rest
    return text


def payload_of(args: argparse.Namespace):
    """``--payload-mass`` and ``--payload-offset`` as a Payload, or None; an offset without a
    mass (it would be dropped) is refused."""
    from modquad_gym import dynamics as dy

    mass = args.payload_mass
    if args.payload_offset is not None and not mass:
        raise ValueError(
            f"--payload-offset {args.payload_offset} places a payload, but there is none: give "
            "--payload-mass (kg, above 0)"
        )
    if not mass:
        return None
    try:
        offset = tuple(parse_real(v) for v in (args.payload_offset or "0,0,0").split(","))
    except ValueError:
        raise ValueError(
            f"--payload-offset must be X,Y,Z in metres, got {args.payload_offset!r}"
        ) from None
    return dy.Payload(mass, offset)


def motion_task(args: argparse.Namespace):
    """The DynamicTask of the parsed options (ValueError naming a misplaced option)."""
    from modquad_gym import dynamics as dy

    given = {k: getattr(args, k) for k in (*OPTION_HELP, "heading") if getattr(args, k) is not None}
    for key in given:
        if key not in PARAMETERS[args.kind]:
            raise ValueError(f"{OPTION_OF[key]} does not apply to --kind {args.kind}")
    if "push_force" in given:
        given["force"] = given.pop("push_force")
    try:
        common = dict(f_max=args.f_max, payload=payload_of(args), rate=args.rate,
                      name=args.kind if args.name is None else args.name)  # fmt: skip
        return dy.MOTIONS[args.kind](**given, **common)
    except LongMotionError as exc:
        raise ValueError(long_motion_message(exc, args)) from None
    except ValueError as exc:
        raise ValueError(option_message(exc, args)) from None


def long_motion_message(exc: LongMotionError, args: argparse.Namespace) -> str:
    """A motion too long to sample, blamed on the typed options among those that set its
    length and ``--rate`` (all of them when none is known to be typed), with their values."""
    from modquad_gym.cli.given import typed

    causes = [*(p for p in exc.lengths if p in PARAMETERS[args.kind]), "rate"]
    blamed = [p for p in causes if typed(args, p)] or causes
    shown = ", ".join(f"{OPTION_OF[p]} {getattr(args, p):g}" for p in blamed)
    options = ", ".join(OPTION_OF[p] for p in causes if p != "rate")
    return (
        f"{shown}: the motion lasts {exc.duration:.6g} s, {exc.samples} samples at --rate "
        f"{exc.rate:g} samples/s, more than the {MAX_SAMPLES:,} a trajectory holds; shorten it "
        f"({options}) or lower --rate"
    )


ACCELERATION_OPTIONS = {
    "hover": (),
    "line": ("max_acceleration",),
    "circle": ("speed", "radius"),
    "figure-eight": ("speed", "size"),
    "push": ("speed",),
}
"""The options that set how hard each kind accelerates (with --f-max, whether a module flies
it)."""


def unflyable_message(args: argparse.Namespace) -> str:
    """A motion whose modules cannot carry their own weight, blamed on the typed options among
    those that set its accelerations and ``--f-max`` (all of them when none is typed)."""
    from modquad_gym.cli.given import typed

    causes = [*ACCELERATION_OPTIONS[args.kind], "f_max"]
    blamed = [p for p in causes if typed(args, p)] or causes
    shown = ", ".join(
        OPTION_OF[p] + ("" if getattr(args, p) is None else f" {getattr(args, p):g}")
        for p in blamed
    )
    motion = ", ".join(OPTION_OF[p] for p in causes if p != "f_max")
    return (
        f"{shown}: a module of type t45 cannot carry its own weight along this --kind "
        f"{args.kind} motion at {args.f_max:g} N per rotor; "
        + (f"slow the motion ({motion}) or raise --f-max" if motion else "raise --f-max")
    )


def cmd_task_motion(args: argparse.Namespace) -> int:
    from modquad_gym.core.outputs import check_output_file
    from modquad_gym.geometry.module import STOCK_TYPES

    out = check_output_file(args.out, force=args.force, what="--out")
    if out.suffix.lower() != ".json":
        raise ValueError(f"--out {out}: a dynamic task is written as .json")
    task = motion_task(args)
    from modquad_gym.dynamics import check_liftable

    try:  # a task no structure flies: refused
        lift = check_liftable(task, [STOCK_TYPES["t45"]])
    except ValueError as exc:
        if str(exc).startswith("f_max:"):
            raise ValueError(unflyable_message(args)) from None
        raise ValueError(option_message(exc, args)) from None
    task.save(out, force=args.force, what="--out")  # checked before the work, and now again
    print(
        f"wrote {out}: {task.n_wrenches} samples over {task.trajectory.duration:.3g} s "
        f"({args.kind}, f_max {task.f_max:g} N; at least {lift} T-module(s) by the lift bound)"
    )
    return 0
