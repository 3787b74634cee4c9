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

from modquad_gym.cli.common import (
    NO_FAULT,
    add_detection_delay,
    add_fault,
    check_fault_method,
    fault_margin_of,
)

DEFAULT_DETECTION_DELAY = 0.02
"""= :data:`modquad_gym.sim.fault_flight.DETECTION_DELAY_S` (here: the parser imports no
simulation)."""

FAULT_HELP = (
    "search for a structure that survives any failure of this kind (rotor: any one rotor "
    "stops; module: any one module's rotors stop; rotor2: any two rotors; rotor+module: a "
    "module's rotors and one rotor of another module), then also fly it "
    "through the failure that leaves the smallest margin, halfway through a hover under the "
    "hardest task wrench (or through the trajectory of a dynamic task), and the same kind of "
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
        refuse_ignored(args, ["detection_delay", "fault_margin", "detect"],
                       "it applies with --fault")  # fmt: skip
    fault_margin_of(args)  # the margin's range, the delay's calibrated range


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


def fault_seconds(args: argparse.Namespace, task) -> float:
    """Simulated seconds of the flights through a failure, one per design (:func:`designs`)."""
    if args.fault is None:
        return 0.0
    from modquad_gym.sim import fault_flight

    return designs(args) * task.flight_seconds(fault_flight.FAULT_HOVER_SECONDS)


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


def fly_fault(args: argparse.Namespace, task, structure, report: dict, solver) -> dict:
    """``report`` with the flights through a failure merged in (``report.md`` and
    ``validation.json`` in ``--out`` updated); ``solver(args_without_fault)`` gives the
    solve function of the intact search (the same method without ``--fault``; whether it
    certified its answer minimal is ``intact_minimum["certified"]``)."""
    if args.fault is None:
        return report
    from modquad_gym.sim import fault_flight
    from modquad_gym.sim.validate_fault import add_to_report, validate_with_failure

    plain = {"fault_margin": None, "detection_delay": None}
    intact_args = argparse.Namespace(**{**vars(args), **plain, "fault": None})
    intact = solver(intact_args)(task)
    delay = DEFAULT_DETECTION_DELAY if args.detection_delay is None else args.detection_delay
    detector = None
    if getattr(args, "detect", False):  # the detector decides in flight; the delay, if given,
        from modquad_gym.sim.detector import DetectorConfig  # set only the design's margin

        detector, delay = DetectorConfig(), None
    record = validate_with_failure(structure, task, args.fault, intact=intact.structure,
                                   out_dir=args.out, detection_delay_s=delay,
                                   detector=detector)  # fmt: skip
    if record["intact_minimum"] is not None:  # the search's word on it being the minimum
        record["intact_minimum"]["certified"] = bool(intact.certified)
    margin = fault_margin_of(args)
    record["fault_margin_required"] = margin or 0.0
    record["fault_margin_delay_s"] = args.detection_delay  # what the margin is for (or None)
    if margin:  # the design without the margin, through its own worst failure, same delay
        from modquad_gym.sim.validate_fault import intact_record

        bare = solver(argparse.Namespace(**{**vars(args), **plain}))(task).structure
        if bare is not None:
            flight = fault_flight.fly_with_failure(
                bare, task, args.fault, detection_delay_s=delay, detector=detector
            )
            record["without_margin"] = intact_record(flight)
    return add_to_report(args.out, report, record)


def _cm(metres) -> str:
    if metres is None:
        return "n/a"
    return f"{100 * metres:.3g} cm" if metres >= 1e-4 else "under 0.1 mm"


def fault_lines(r: dict) -> list[str]:
    """The console lines of the flights through a failure (none without them)."""
    if r.get("fault_flight") is None:
        return []
    from modquad_gym.sim.fault_pictures import failed_part_words

    def line(name: str, x: dict, tolerates: bool) -> str:
        part = failed_part_words(x)  # numbered from 1, as rows and cells are
        return (
            f"{name}: {'tolerates' if tolerates else 'does not tolerate'} any {r['fault']} "
            f"failure; {part} stopped at {x['fault_time_s']:.3g} s: position error after it up "
            f"to {_cm(x['fault_max_position_error_m'])}, a working rotor at a limit in "
            f"{100 * x['fault_saturated_fraction']:.3g} % of steps"
            + (f" ({x['fault_diverged']})" if x.get("fault_diverged") else "")
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
