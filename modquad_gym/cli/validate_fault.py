"""``modquad validate --fault rotor|module``: the structure found by the fault-tolerant search
flown through its worst single failure, and the intact minimum of the same task through its own
(:func:`modquad_gym.sim.validate_fault.validate_with_failure`).

The parts :mod:`modquad_gym.cli.validate` calls: :func:`add_fault_options` (``--fault``,
``--detection-delay``), :func:`check_fault_options` (before any work), :func:`fault_output_names`
and :func:`fault_seconds` (the output check and the time estimate), :func:`fly_fault` (after the
validation: the flights, pictures, report section and JSON keys), :func:`no_structure_keys` and
:func:`fault_lines` (the console summary).
"""

from __future__ import annotations

import argparse
import sys

from modquad_gym.cli.common import (
    NO_FAULT,
    add_detection_delay,
    add_fault,
    check_fault_method,
    fault_margin_of,
    palette,
)
from modquad_gym.core.options import real_option


def failure_option(text: str) -> str | int:
    """An argparse ``type`` for ``--failure``: ``all``, ``worst`` or a number from 1."""
    if text in ("all", "worst"):
        return text
    if text.isdigit() and int(text) >= 1:
        return int(text)
    raise argparse.ArgumentTypeError(f"expected all, worst or a number from 1, got {text!r}")


DEFAULT_DETECTION_DELAY = 0.02
"""= :data:`modquad_gym.sim.fault_flight.DETECTION_DELAY_S` (here: the parser imports no
simulation)."""

DEFAULT_FAULT_SECONDS = 3.0
"""= :data:`modquad_gym.sim.fault_flight.FAULT_SECONDS` (``--fault-seconds``' default)."""

MAX_FAULT_SECONDS = 60.0
"""= :data:`modquad_gym.sim.fault_flight.MAX_FAULT_SECONDS`."""

SECONDS_PER_FAULT_FLIGHT_SECOND = 0.05
"""Wall seconds per simulated second and module of a flight through a failure (2 cores;
measured: 24 flights of a 6-module line, 4 simulated s each, 25 s; a saturated flight is slower,
up to 0.12), for the estimate said before many failures are flown."""

SAY_ESTIMATE_S = 10.0
"""The flights through the failures are announced on stderr when estimated longer than this."""

FAULT_HELP = (
    "search for a structure that survives any failure of this kind (rotor: any one rotor "
    "stops; module: any one module's rotors stop; rotor2: any two rotors; rotor+module: a "
    "module's rotors and one rotor of another module), then also fly it "
    "through its failures (--failure), 1 s into a hover under each failure's "
    "hardest task wrench (or along the trajectory of a dynamic task, then going on as it "
    "ended: see --fault-seconds), and the same kind of "
    "failure on the intact minimum of the task for comparison; --json adds "
    "fault_max_position_error_m, fault_saturated_fraction, the failed rotors and "
    "intact_minimum; pictures fault_flight*.png. Every method but "
    f"{NO_FAULT} takes it (the learned ones, for a rotor failure of T-modules alone below "
    "--n-max 16, with the model trained with it, ppo_fault, otherwise zero-shot; each answer "
    "verified to survive)"
)


def add_fault_options(p: argparse.ArgumentParser) -> None:
    """``--fault``, ``--fault-margin``, ``--detection-delay`` and ``--detect``."""
    add_fault(p, FAULT_HELP)
    add_detect_option(p)
    p.add_argument(
        "--fault-seconds", type=real_option, default=None, metavar="SECONDS",
        help="with --fault: simulated seconds each flight goes on after the failure "
        f"(default {DEFAULT_FAULT_SECONDS:g}, at most {MAX_FAULT_SECONDS:g}, at least the "
        "detection delay plus 1 s: the settling test compares the last two 0.5 s windows); a "
        "dynamic task flies its trajectory to the end, then goes on as it ended (at rest at "
        "its last point for one that ends at rest), its load still applied, until then and at "
        "least 1 s after the end. Python: fly_with_failure(seconds=)",
    )  # fmt: skip
    p.add_argument(
        "--failure", type=failure_option, default="all", metavar="{all,worst,K}",
        help="with --fault: which failures the found structure flies: all (default: every one; "
        "the verdict and the error reported are the worst over them, the failure that gave it "
        "named), worst (the smallest-margin failure only) or K (rotor K, 1..4n, for --fault "
        "rotor; module K, 1..n, for --fault module; numbered as the console prints them; the "
        "intact minimum then flies its smallest-margin failure only). Python: "
        "fly_with_failure(failure=)",
    )  # fmt: skip
    add_detection_delay(
        p,
        "with --fault: design for a controller that learns of the failure this many "
        "seconds late (the required --fault-margin derived from it, as `modquad solve "
        "--detection-delay`; 0 to 0.05; JSON key fault_margin_delay_s) and fly with that delay "
        "(with --detect the detector decides in flight when the controller learns of it, and "
        "the delay sets only the design's margin); the design without the margin is flown "
        "beside it (JSON key without_margin). Without it the flights use "
        f"{DEFAULT_DETECTION_DELAY:g} s and the design has no margin",
    )


def add_detect_option(p: argparse.ArgumentParser) -> None:
    """``--detect``: the flights through the failure with the in-flight detector."""
    p.add_argument(
        "--detect",
        action="store_true",
        help="with --fault: the controller is not told of the failure; a "
        "detector on its noisy velocity and body rate decides when and which rotors failed "
        "(modquad_gym.sim.detector) and the allocator switches on its decision, whenever that "
        "comes (a --detection-delay sets only the design's margin); --json adds "
        "fault_detected_after_s (the delay flown; fault_detection_delay_s is null), "
        "fault_detected_rotors (named last: a wrong isolation is revised when the residual "
        "stays) and fault_detector_decisions",
    )


def check_fault_options(args: argparse.Namespace) -> None:
    """``--fault`` with a method that cannot honour it (:data:`~.common.NO_FAULT`),
    ``--detection-delay`` out of range or without ``--fault``: one line, before any work."""
    from modquad_gym.cli.given import refuse_ignored

    check_fault_method(args)
    if args.fault is None:
        refuse_ignored(args, ["detection_delay", "fault_margin", "detect", "fault_seconds",
                              "failure"], "it applies with --fault")  # fmt: skip
    fault_margin_of(args)  # the margin's range, the delay's calibrated range
    if isinstance(getattr(args, "failure", None), int) and args.fault not in ("rotor", "module"):
        raise ValueError(f"--failure {args.failure}: a numbered failure applies to --fault "
                         f"rotor or module, not {args.fault}; give all or worst")  # fmt: skip
    if isinstance(getattr(args, "failure", None), int) and hasattr(args, "n_max"):
        _check_failure_number(args)
    if getattr(args, "fault_seconds", None) is not None:
        delay = 0.0 if getattr(args, "detect", False) else flown_delay(args)
        least = delay + 1.0
        if not least <= args.fault_seconds <= MAX_FAULT_SECONDS:
            raise ValueError(
                f"--fault-seconds {args.fault_seconds:g}: must lie in [{least:g}, "
                f"{MAX_FAULT_SECONDS:g}] s (the detection delay {delay:g} s, then two 0.5 s "
                "windows of the settling test)"
            )


def _check_failure_number(args: argparse.Namespace) -> None:
    """``--failure K`` (rotor or module faults) within what ``--n-max`` modules have."""
    rotors = max((m.n_rotors for m in palette(args) or []), default=4)
    most = failures_at(args.fault, args.n_max, rotors)
    if args.failure > most:
        raise ValueError(f"--failure {args.failure}: a structure of at most --n-max "
                         f"{args.n_max} modules has at most {most} {args.fault}s, numbered "
                         f"1..{most}")  # fmt: skip


def flown_delay(args: argparse.Namespace) -> float:
    """The detection delay the flights fly without ``--detect``."""
    return DEFAULT_DETECTION_DELAY if args.detection_delay is None else args.detection_delay


def fault_output_names(args: argparse.Namespace) -> tuple[str, ...]:
    """What ``--fault`` adds to ``--out`` (:data:`modquad_gym.sim.validate_fault.FAULT_FILES`)."""
    if args.fault is None:
        return ()
    from modquad_gym.sim.validate_fault import FAULT_FILES

    return FAULT_FILES


def designs(args: argparse.Namespace) -> int:
    """How many structures ``--fault`` searches and flies: the tolerant one and the intact
    minimum, and with a margin (``--fault-margin``, ``--detection-delay``) the design without
    it (0 without ``--fault``)."""
    if args.fault is None:
        return 0
    return 3 if fault_margin_of(args) else 2


def failures_at(fault: str, n: int, rotors: int = 4) -> int:
    """How many failures of kind ``fault`` a structure of ``n`` modules of ``rotors`` rotors has
    (:func:`modquad_gym.oracle.failures.failure_sets`' count): each rotor, each module, each pair
    of rotors, or each module with each rotor of another."""
    r = n * rotors
    return {"rotor": r, "module": n, "rotor2": r * (r - 1) // 2,
            "rotor+module": n * (r - rotors) if n > 1 else 1}[fault]  # fmt: skip


def least_modules(args: argparse.Namespace, task) -> int:
    """The fewest modules a structure tolerating ``--fault`` can have by the task's forces alone
    (:func:`~modquad_gym.search.bounds.force_lower_bound`, over ``--modules``' types, the task's
    wrenches without the structure's own weight and dynamics), within ``--n-max``: the size the
    up-front estimate assumes, before the search finds the structure (1 where not bounded)."""
    from modquad_gym.geometry.module import TModule
    from modquad_gym.search.bounds import force_lower_bound

    try:
        W = task.static_wrenches() if _dynamic(task) else task.rotor_wrenches(0.0)
        types = palette(args) or [TModule()]
        least = min(force_lower_bound(W, m, task.f_max, args.fault) for m in types)
    except (ValueError, AttributeError):  # an unusual task: no bound, not an error here
        least = 1
    return max(1, min(least, getattr(args, "n_max", least) or least))


def fault_flights(args: argparse.Namespace, n: int) -> int:
    """How many flights through a failure ``validate --fault`` flies when the found structure
    has ``n`` modules (the intact minimum and the design without the margin assumed no larger):
    every failure (``--failure all``) or one, per design (:func:`designs`)."""
    if args.fault is None:
        return 0
    from modquad_gym.sim.validate_fault import others_choice

    each = failures_at(args.fault, n)
    found = each if args.failure == "all" else 1
    theirs = each if others_choice(args.failure) == "all" else 1
    return found + (designs(args) - 1) * theirs


def fault_seconds(args: argparse.Namespace, task, n: int = 1) -> float:
    """Simulated seconds of the flights (:func:`fault_flights`) at ``n`` modules."""
    if args.fault is None:
        return 0.0
    return fault_flights(args, n) * _flight_seconds(args, task)


def fault_wall_seconds(args: argparse.Namespace, task, n: int = 1) -> float:
    """About how long here the flights through a failure take at ``n`` modules
    (:data:`SECONDS_PER_FAULT_FLIGHT_SECOND` per simulated second and module)."""
    return fault_seconds(args, task, n) * n * SECONDS_PER_FAULT_FLIGHT_SECOND


def flights_words(args: argparse.Namespace, n: int, wall: float) -> str:
    """What the refusal of a long run says of the flights through a failure (empty without
    ``--fault``)."""
    if args.fault is None:
        return ""
    return (f" and flying {fault_flights(args, n):,} flights through a {args.fault} failure "
            f"(--failure {args.failure}, at {n} modules; about {wall:,.0f} s of it)")  # fmt: skip


def fewer_words(args: argparse.Namespace) -> str:
    """The refusal's advice on the flights (empty unless every failure is flown)."""
    return ", fly one failure (--failure worst)" if args.failure == "all" and args.fault else ""


def check_found(args: argparse.Namespace, task, structure, limit: float) -> None:
    """Once the search has found ``structure``, before the bench and the hovers: ``--failure K``
    within its failures, and the flights through its failures (the intact minimum and the design
    without the margin assumed no larger) within ``limit`` s unless ``--allow-long``. A
    ValueError naming the option otherwise."""
    if args.fault is None:
        return
    from modquad_gym.sim import fault_flight

    count = len(fault_flight.failure_columns(structure, args.fault))
    if isinstance(args.failure, int) and args.failure > count:
        raise ValueError(f"--failure {args.failure}: the structure found has {count} "
                         f"{args.fault}s, numbered 1..{count}")  # fmt: skip
    wall = fault_wall_seconds(args, task, structure.n_modules)
    if wall > limit and not getattr(args, "allow_long", False):
        raise ValueError(
            f"{args.task}: the structure found has {structure.n_modules} modules; flying "
            f"{fault_flights(args, structure.n_modules):,} flights through a {args.fault} "
            f"failure (--failure {args.failure}) takes about {wall:,.0f} s, more than "
            f"{limit:,.0f} s;{fewer_words(args).lstrip(',')} or give --allow-long"
        )


def _flight_seconds(args: argparse.Namespace, task) -> float:
    """Simulated seconds of one flight through a failure (the hover before it included; a
    trajectory's hold after its end included, the failure assumed at its latest:
    :func:`~modquad_gym.sim.fault_flight.flight_seconds`)."""
    from modquad_gym.sim import fault_flight

    after = getattr(args, "fault_seconds", None) or fault_flight.FAULT_SECONDS
    return fault_flight.flight_seconds(task, after)


def search_seconds_text(args: argparse.Namespace) -> str:
    """What the estimate adds for the searches: one per design (:func:`designs`), each kept
    within ``--time-limit`` when one is given."""
    limit = getattr(args, "time_limit", None)
    if args.fault is None or limit is None:
        return ""
    return f", plus {('two', 'three')[designs(args) - 2]} searches of at most {limit:g} s each"


def no_structure_keys(args: argparse.Namespace) -> dict:
    """The fault keys of a record without a structure (no tolerant one up to --n-max)."""
    if args.fault is None:
        return {}
    return {"fault": args.fault, "fault_max_position_error_m": None,
            "fault_saturated_fraction": None}  # fmt: skip


def fly_fault(args: argparse.Namespace, task, structure, report: dict, solver, page) -> dict:
    """``report`` with the flights through a failure merged in (``page``, the validation's
    report.md, then written once with it); ``solver(args_without_fault)`` gives the
    solve function of the intact search (the same method without ``--fault``; whether it
    certified its answer minimal is ``intact_minimum["certified"]``)."""
    if args.fault is None:
        return report
    from modquad_gym.sim import fault_flight
    from modquad_gym.sim.validate_fault import add_to_report, validate_with_failure

    plain = {"fault_margin": None, "detection_delay": None}
    intact_args = argparse.Namespace(**{**vars(args), **plain, "fault": None})
    intact = solver(intact_args)(task)
    delay, detector = flown_delay(args), None
    if getattr(args, "detect", False):  # the detector decides in flight; the delay, if given,
        from modquad_gym.sim.detector import DetectorConfig  # set only the design's margin

        detector, delay = DetectorConfig(), None
    margin = fault_margin_of(args)
    bare = solver(argparse.Namespace(**{**vars(args), **plain}))(task).structure if margin else None
    flown = dict(detection_delay_s=delay, detector=detector, progress=not args.quiet,
                 seconds=args.fault_seconds)  # fmt: skip
    say_estimate(args, task, [structure, intact.structure, bare])
    record = validate_with_failure(structure, task, args.fault, intact=intact.structure,
                                   out_dir=args.out, force=args.force, failure=args.failure,
                                   **flown)  # fmt: skip
    if record["intact_minimum"] is not None:  # the search's word on it being the minimum
        record["intact_minimum"]["certified"] = bool(intact.certified)
    record["fault_margin_required"] = margin or 0.0
    record["fault_margin_delay_s"] = args.detection_delay  # what the margin is for (or None)
    if bare is not None:  # the design without the margin, through its own failures, same delay
        from modquad_gym.sim.validate_fault import intact_record, others_choice

        theirs = others_choice(args.failure)
        flight = fault_flight.fly_with_failure(bare, task, args.fault, failure=theirs, **flown)
        record["without_margin"] = intact_record(flight)
    return add_to_report(page, report, record)


def _dynamic(task) -> bool:
    return getattr(task, "kind", None) == "dynamic"


def say_estimate(args: argparse.Namespace, task, structures: list) -> None:
    """On stderr, how many failures the designs fly and about how long that takes (measured
    :data:`SECONDS_PER_FAULT_FLIGHT_SECOND` per module), when more than :data:`SAY_ESTIMATE_S`
    (a bar follows unless ``--quiet``)."""
    from modquad_gym.sim import fault_flight
    from modquad_gym.sim.validate_fault import others_choice

    seconds = _flight_seconds(args, task)
    count, wall = 0, 0.0
    for i, s in enumerate(x for x in structures if x is not None):
        choice = args.failure if i == 0 else others_choice(args.failure)
        n = len(fault_flight.failure_columns(s, args.fault)) if choice == "all" else 1
        count += n
        wall += n * seconds * s.n_modules * SECONDS_PER_FAULT_FLIGHT_SECOND
    if wall > SAY_ESTIMATE_S:
        print(f"validate --fault: {count} flights through a {args.fault} failure (--failure "
              f"{args.failure}), {seconds:g} simulated s each: about {wall:.0f} s here",
              file=sys.stderr)  # fmt: skip


def _cm(metres) -> str:
    if metres is None:
        return "n/a"
    return f"{100 * metres:.3g} cm" if metres >= 1e-4 else "under 0.1 mm"


def fault_lines(r: dict) -> list[str]:
    """The console lines of the flights through a failure (none without them)."""
    if r.get("fault_flight") is None:
        return []
    from modquad_gym.sim.fault_pictures import failed_part_words
    from modquad_gym.sim.validate_fault import flown_words, verdict_words

    def line(name: str, x: dict, tolerates: bool) -> str:
        part = failed_part_words(x)  # numbered from 1, as rows and cells are
        x = {"fault": r["fault"], **x}
        return (
            f"{name}: {'tolerates' if tolerates else 'does not tolerate'} any {r['fault']} "
            f"failure; flew {flown_words(x)}; "
            + ("the worst in flight: " if x.get("fault_failure") == "all" else "")
            + f"{part} stopped at {x['fault_time_s']:.3g} s: position error after it up "
            f"to {_cm(x['fault_max_position_error_m'])}, a working rotor at a limit in "
            f"{100 * x['fault_saturated_fraction']:.3g} % of steps; "
            f"{verdict_words(x).replace('no: ', 'does not hold: ')}"
        )

    lines = [line("fault flight", r, r["fault_tolerates"])]
    bare = r.get("without_margin")
    if bare:
        lines.append(line(f"without the margin ({bare['n_modules']} modules)", bare,
                          bare["tolerates"]))  # fmt: skip
    intact = r.get("intact_minimum")
    if intact:
        lines.append(line(f"intact minimum ({intact['n_modules']} modules)", intact,
                          intact["tolerates"]))  # fmt: skip
    return lines
