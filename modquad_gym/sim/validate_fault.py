"""A validation through a failure: a structure and the intact minimum of its task flown through
their worst single failure (:func:`modquad_gym.sim.fault_flight.fly_with_failure`), the pictures
(:mod:`modquad_gym.sim.fault_pictures`), a section of the validation's ``report.md`` and the
JSON keys (``modquad validate --fault rotor|module``).
"""

from __future__ import annotations

import math
from pathlib import Path

from modquad_gym.geometry.structure import Structure
from modquad_gym.sim.fault_flight import FaultFlight, fly_with_failure
from modquad_gym.sim.fault_pictures import failed_part_words, plot_fault_flight
from modquad_gym.sim.validation_files import ReportPage, hold_out_dir

FAULT_FILES = ("fault_flight.png", "fault_flight_intact_minimum.png")
"""The pictures :func:`validate_with_failure` writes (the second with an intact minimum)."""


def intact_record(flight: FaultFlight) -> dict:
    """The comparison record of the intact minimum: its cells, size, module types, whether it
    tolerates the fault, its worst margin and its ``fault_*`` flight keys."""
    s = flight.structure
    record = flight.summary()
    return {
        "cells": [list(c) for c in s.cells],
        "n_modules": s.n_modules,
        "modules": [m.name for m in s.modules],
        "tolerates": flight.worst.tolerates,
        "worst_fault_margin": record.pop("fault_worst_margin"),
        **{k: v for k, v in record.items() if k not in ("fault", "fault_tolerates")},
    }


def others_choice(failure: str | int) -> str:
    """Which failures the intact minimum (and the design without the margin) fly for the found
    structure's ``failure``: the same, but the smallest-margin one where a number was asked
    (its numbering is the found structure's)."""
    return "worst" if isinstance(failure, int) else failure


def validate_with_failure(
    structure: Structure,
    task,
    fault: str,
    intact: Structure | None = None,
    out_dir: str | Path | None = None,
    force: bool = False,
    **options,
) -> dict:
    """Fly ``structure`` through its failures (:func:`fly_with_failure`, ``options`` passed on:
    every one by default) and, when given, the intact minimum ``intact`` through its own failures
    of the same kind (:func:`others_choice`); with ``out_dir`` the pictures ``fault_flight.png`` and
    ``fault_flight_intact_minimum.png`` (:func:`~modquad_gym.sim.fault_pictures.plot_fault_flight`),
    the folder held before any flight as ``validate(out_dir=)`` holds it
    (:func:`~modquad_gym.sim.validation_files.hold_out_dir`: an existing picture replaced only with
    ``force``; within ``modquad validate``'s own hold of the folder, held again).

    Returns the ``fault_*`` keys of ``structure``'s flight, ``intact_minimum``
    (:func:`intact_record`, or None without ``intact``) and ``fault_files`` (picture paths)."""
    names = FAULT_FILES if intact is not None else FAULT_FILES[:1]
    with hold_out_dir(out_dir, names, force) as d:
        flight = fly_with_failure(structure, task, fault, **options)
        record = flight.summary()
        theirs = {**options, "failure": others_choice(options.get("failure", "all"))}
        other = fly_with_failure(intact, task, fault, **theirs) if intact is not None else None
        record["intact_minimum"] = intact_record(other) if other is not None else None
        record["fault_files"] = {}
        if d is not None:
            end = _trajectory_end(task)
            plot_fault_flight(flight, d / FAULT_FILES[0], "found structure", end)
            record["fault_files"]["fault_flight"] = str(d / FAULT_FILES[0])
            if other is not None:
                plot_fault_flight(other, d / FAULT_FILES[1], "intact minimum", end)
                record["fault_files"]["fault_flight_intact_minimum"] = str(d / FAULT_FILES[1])
    return record


def _trajectory_end(task) -> float | None:
    """A dynamic task's trajectory duration (where its pictures mark the hold), else None."""
    return float(task.trajectory.duration) if getattr(task, "kind", None) == "dynamic" else None


def fault_markdown(record: dict, n_modules: int | str = "") -> str:
    """The section of ``report.md`` on the flight through the failure (``n_modules``: the
    found structure's size)."""

    def row(name: str, r: dict, n_modules, tolerates) -> str:
        err = r.get("fault_max_position_error_m")
        err_text = "n/a" if err is None else f"{100 * err:.3g} cm"
        part = failed_part_words(r)
        margin_ = r.get("fault_worst_margin", r.get("worst_fault_margin"))
        flown = r.get("fault_flown_margin", margin_)
        return (
            f"| {name} | {n_modules} "
            f"| {'yes' if tolerates else 'no'} | {_fmt(margin_)} | {part} | {_fmt(flown)} "
            f"| {r['fault_time_s']:.3g} s | {_told(r)} | {err_text} "
            f"| {100 * r['fault_saturated_fraction']:.3g} % "
            f"| {r.get('fault_diverged') or 'no'} | {verdict_words(r)} |"
        )

    lines = [
        f"## Flight through a {record['fault']} failure",
        "",
        f"{flown_words(record).capitalize()} strikes during the {record['fault_flight']} (its "
        "thrust forced to 0; for a hover after 1 s of it, for a trajectory halfway or half a "
        "second before the moment it hurts most if that comes earlier), each failure under "
        f"its own hardest task wrench; {_switch_words(record)} Errors and saturation (some "
        "working rotor at 0 or f_max) are measured from the failure on; the row is the flight "
        "that did worst. *worst margin* is the smallest margin over every failure of the kind "
        "(as `modquad solve --json`'s worst_fault_margin), *its margin* that of the failure "
        "flown in the row. It holds when never stopped, within 5 cm and settled at the end (the "
        "largest error of the last 0.5 s not above the 0.5 s before, by more than 10 % plus "
        "0.1 mm, and at least one step of the last 0.5 s with no working rotor at a limit; a "
        "flight judged not settled only for a rotor still at a limit, its error not growing, "
        "may be a slow recovery that a longer --fault-seconds shows).",
        "",
        "| structure | modules | tolerates | worst margin | failed | its margin | at "
        "| controller told after | max position error after | saturated after | diverged "
        "| holds |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
        row("found", record, n_modules, record["fault_tolerates"]),
    ]
    intact = record.get("intact_minimum")
    if intact:
        lines.append(row("intact minimum", intact, intact["n_modules"], intact["tolerates"]))
    lines.append("")
    for path in (record.get("fault_files") or {}).values():
        lines.append(f"![{Path(path).stem}]({Path(path).name})")
    return "\n".join(lines) + "\n"


def flown_words(r: dict) -> str:
    """Which failures the flight record ``r`` flew, in words."""
    choice, n = r.get("fault_failure", "worst"), r.get("fault_failures_flown", 1)
    if choice == "all":
        return f"each of the {n} {r['fault']} failures"
    if choice == "worst":
        return f"the smallest-margin {r['fault']} failure only"
    return f"the {r['fault']} failure asked for (--failure {choice})"


def verdict_words(r: dict) -> str:
    """``holds`` or why not (stopped, beyond 5 cm, not settled: the error trend and
    saturation) for a flight record ``r``."""
    return "holds" if r.get("fault_within_5cm") else f"no: {r.get('fault_why_not') or 'n/a'}"


def _switch_words(record: dict) -> str:
    """When the controller learned of the failure in these flights: after the fixed delay, or
    when the detector decided (a ``--detection-delay`` then set only the design's margin)."""
    delay = record.get("fault_detection_delay_s")
    if delay is not None:
        return f"{delay:g} s later the allocator and the gains drop its columns."
    words = ("the controller is not told: a detector on its noisy velocity and body rate decides "
             "when and which rotors failed (column *controller told after*), and the allocator "
             "and the gains then drop the columns it named.")  # fmt: skip
    designed = record.get("fault_margin_delay_s")
    if designed is not None:
        words += (f" The design keeps the margin for a {designed:g} s detection delay "
                  "(--detection-delay); the delay flown is the detector's.")  # fmt: skip
    return words


def _told(r: dict) -> str:
    """How long after the failure the controller of the flight ``r`` switched."""
    if r.get("fault_detection_delay_s") is not None:
        return f"{r['fault_detection_delay_s']:g} s"
    after = r.get("fault_detected_after_s")
    if after is None:
        return "never (detector)"
    revised = "".join(
        f"; revised at {t:.3g} s" for t, _ in (r.get("fault_detector_decisions") or [])[1:]
    )
    return f"{after:.3g} s (detector{revised})"


def _fmt(x) -> str:
    return "n/a" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.3g}"


def add_to_report(page: ReportPage, report: dict, record: dict) -> dict:
    """``report`` (a validation record) with the fault ``record`` merged in (pictures into
    ``files``); :func:`fault_markdown` goes into the validation's ``page`` (the one it was
    flown with: ``validate(page=...)``), which is then written, ``report.md`` and
    ``validation.json`` (the merged record) each once. Returns the merged record."""
    from modquad_gym.core.outputs import json_ready

    merged = json_ready({**report, **{k: v for k, v in record.items() if k != "fault_files"}})
    merged["files"] = {**(report.get("files") or {}), **record.get("fault_files", {})}
    page.sections.append(fault_markdown(record, report.get("n_modules", "")))
    page.write(merged)
    return merged
