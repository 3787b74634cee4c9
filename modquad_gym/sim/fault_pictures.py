"""The picture of a flight through a failure (:class:`~modquad_gym.sim.fault_flight.FaultFlight`).

One figure: the COM's path (3D; before the failure blue, after it orange, the failure marked; a
hover's path is drawn in centimetres about home), the position error over time with the 5 cm
goal (scaled to the data, at least to :data:`MIN_SCALE_CM`) and the rotor inputs over time
(:func:`~modquad_gym.sim.pictures.inputs_panel`: one line per rotor, the failed ones drawn thick
and dashed in red, or a heat map for many rotors with the failed rows framed), a vertical line in
both at the failure, at when it was known, and, for a trajectory flown on past its end (the hold
after it), at the trajectory's end (:func:`time_marks`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.core.outputs import save_figure
from modquad_gym.sim.fault_flight import GOAL_M, FaultFlight
from modquad_gym.sim.pictures import MAX_LINES, OUTSIDE, inputs_panel

BEFORE, AFTER, FAILURE, END = "tab:blue", "tab:orange", "tab:red", "tab:green"

MIN_SCALE_CM = 0.1
"""The error panel shows at least 0 to 1 mm: a flight held to round-off stays a flat line."""


MARK_ROWS = (0.97, 0.85, 0.73)
"""Heights (fractions of the error panel) of the marks' words, above the data (the panel's top
is 1.15 x 1.15 the largest error): each mark's words on the first row where they overlap no
other's."""


@dataclass(frozen=True)
class TimeMark:
    """A vertical line across both time-axis panels at ``time_s``, ``words`` beside it at the top
    of the error panel."""

    time_s: float
    words: str
    color: str
    ls: str = "-"
    lw: float = 1.5


def time_marks(flight: FaultFlight, trajectory_end_s: float | None = None) -> list[TimeMark]:
    """The marks on the time axis: the failure; when it was known, where later; and, for a
    trajectory flight that goes on past ``trajectory_end_s`` (the trajectory's duration: the
    hold after it), the trajectory's end. A hover, or no ``trajectory_end_s``, has no end
    mark."""
    marks = [TimeMark(flight.failure.time_s, f" {flight.fault} fails", FAILURE)]
    known = _detected(flight)
    if known is not None:
        marks.append(TimeMark(known, " known", "0.2", ls=":", lw=1.2))
    t = flight.run.t
    if (flight.flight == "trajectory" and trajectory_end_s is not None and len(t)
            and t[-1] > trajectory_end_s + 1e-9):  # fmt: skip
        marks.append(TimeMark(float(trajectory_end_s), " trajectory ends, hold", END))
    return marks


def plot_fault_flight(flight: FaultFlight, path: str | Path, label: str = "",
                      trajectory_end_s: float | None = None) -> None:  # fmt: skip
    """Write :func:`fault_flight_figure` to ``path`` (PNG)."""
    save_figure(fault_flight_figure(flight, label, trajectory_end_s), path, dpi=120)


def fault_flight_figure(flight: FaultFlight, label: str = "",
                        trajectory_end_s: float | None = None):  # fmt: skip
    """The figure of the module docstring (a ``matplotlib.figure.Figure``, no pyplot);
    ``trajectory_end_s``: a trajectory's duration, marked where the flight holds after it
    (:func:`time_marks`)."""
    Figure = import_optional("matplotlib.figure").Figure

    run, failure = flight.run, flight.failure
    fig = Figure(figsize=(13, 7.5))
    grid = fig.add_gridspec(2, 2, width_ratios=[1, 1.5])
    _path_panel(fig.add_subplot(grid[:, 0], projection="3d"), flight)
    ax_err = fig.add_subplot(grid[0, 1])
    ax_u = fig.add_subplot(grid[1, 1], sharex=ax_err)
    _error_panel(ax_err, run.t, 100 * run.position_error, 100 * GOAL_M)
    ax_err.set_ylabel("position error [cm]")
    ax_err.set_title(
        f"after the failure: max {_cm(flight.max_position_error_m)}, "
        f"saturated {100 * flight.saturated_fraction:.3g} % of control steps"
        + (f"\nstopped: {run.diverged}" if run.diverged else ""),
        fontsize=10,
    )
    inputs_panel(fig, ax_u, run.t, run.inputs, run.f_max)
    _mark_failed(ax_u, run, failure.columns)
    if run.inputs.shape[1] > MAX_LINES:  # the heat map's colour bar: the same room above
        fig.colorbar(ax_u.collections[0], ax=ax_err, pad=0.01).ax.set_visible(False)
    ax_u.set_xlabel("time [s]")
    known = _detected(flight)
    marks = time_marks(flight, trajectory_end_s)
    for ax in (ax_err, ax_u):
        if known is not None:
            ax.axvspan(failure.time_s, known, color=FAILURE, alpha=0.12, lw=0)
        for mark in marks:
            ax.axvline(mark.time_s, color=mark.color, lw=mark.lw, ls=mark.ls, zorder=5)
    fig.suptitle(_title(flight, label), fontsize=11)
    fig.tight_layout(w_pad=4.0)  # room for the 3-D panel's z label beside the error axis
    _mark_words(ax_err, marks)  # after the layout: the words' extents are final
    return fig


def _mark_words(ax, marks: list[TimeMark]) -> None:
    """Each mark's words beside its line, right of it (left where they would run past the
    panel's edge), on the first of :data:`MARK_ROWS` where they overlap none of the words placed
    before (where every row does: the first)."""
    edge = ax.get_window_extent().x1
    places = [(row, ha) for row in MARK_ROWS for ha in ("left", "right")]
    placed: list = []
    for mark in marks:
        text = ax.text(mark.time_s, MARK_ROWS[0], "", color=mark.color, fontsize=9, va="top",
                       transform=ax.get_xaxis_transform())  # fmt: skip
        for row, ha in [*places, places[0]]:
            text.set_y(row)
            text.set_horizontalalignment(ha)
            text.set_text(mark.words if ha == "left" else mark.words.strip() + " ")
            box = text.get_window_extent()
            if box.x1 <= edge and not any(box.overlaps(b) for b in placed):
                break
        placed.append(box)


def failed_part_words(part: dict) -> str:
    """The failed part of a record (:meth:`~.fault_record.FaultFlight.failed_part`'s keys and
    ``fault_failed_rotors``) in words, numbered from 1 as the command line numbers rows, cells
    and ``--failure K``: ``rotor 6 (rotor 2 of module 2 at cell (0, 1))`` (the record's indices
    are 0-based: module 1 is ``cells[1]``, rotor 6 is column 5)."""
    what = f"module {part['fault_failed_module'] + 1} at cell {tuple(part['fault_failed_cell'])}"
    parts, rotors = part.get("fault_failed_parts"), part.get("fault_failed_rotors") or []
    if parts and part.get("fault_failed_rotor_in_module") is None:  # a module (and a rotor)
        if parts[-1]["module"] == part["fault_failed_module"]:  # one module: it alone fails
            return what
        return f"{what} and rotor {rotors[-1] + 1} ({_rotor_words(parts[-1])})"
    if parts:  # a pair of rotors
        return (f"rotors {' and '.join(str(c + 1) for c in rotors)} "
                f"({' and '.join(_rotor_words(p) for p in parts)})")  # fmt: skip
    if part.get("fault_failed_rotor_in_module") is not None:
        what = f"rotor {part['fault_failed_rotor_in_module'] + 1} of {what}"
        rotors = part.get("fault_failed_rotors") or []
        if len(rotors) == 1:  # its number among all the rotors (--failure K)
            what = f"rotor {rotors[0] + 1} ({what})"
    return what


def _rotor_words(where: dict) -> str:
    """One failed rotor of a ``fault_failed_parts`` entry, numbered from 1."""
    return (f"rotor {where['rotor_in_module'] + 1} of module {where['module'] + 1} at cell "
            f"{tuple(where['cell'])}")  # fmt: skip


KIND_WORDS = {"rotor": "single rotor", "module": "single module", "rotor2": "two-rotor",
              "rotor+module": "module-and-rotor"}  # fmt: skip
"""The kind of failure in a title: "any <words> failure"."""


def _title(flight: FaultFlight, label: str) -> str:
    s = flight.structure
    part = {**flight.failed_part(), "fault_failed_rotors": list(flight.failure.columns)}
    what = failed_part_words(part)
    tolerant = "tolerates" if flight.worst.tolerates else "does NOT tolerate"
    head = f"{label}: " if label else ""
    task = f" - task {flight.task_name}" if flight.task_name else ""
    margin, delay = flight.worst.margin, flight.failure.detection_delay_s
    left = f"{margin:.3g}" if np.isfinite(margin) else "-inf: off the working rotors' span"
    return (
        f"{head}{s.n_modules} modules, {tolerant} any {KIND_WORDS[flight.fault]} "
        f"failure{task}\n"
        f"{flight.flight}: {_which(flight)} ({what}, margin after it "
        f"{left}) at t = {flight.failure.time_s:.3g} s, "
        + (f"known {delay:g} s later" if delay > 0 else "known at once")
    )


def _which(flight: FaultFlight) -> str:
    """Which failure the picture shows, among those flown."""
    if flight.choice == "all":
        return f"the failure that did worst in flight of all {len(flight.each)} flown"
    if flight.choice == "worst":
        return "the smallest-margin failure only"
    return f"failure {flight.choice} (asked for)"


def _detected(flight: FaultFlight) -> float | None:
    """When the controller learned of the failure: the fixed delay's end, or the detector's
    first decision (None: never, or at once)."""
    detection = getattr(flight.run, "detection", None)
    if getattr(flight.run, "detector", None) is not None:
        return None if detection is None else float(detection[0])
    return flight.failure.detected_s if flight.failure.detection_delay_s > 0 else None


def _cm(metres: float) -> str:
    if metres < 1e-4:
        return "under 0.1 mm"
    return f"{100 * metres:.3g} cm" if metres < 1.0 else f"{metres:.3g} m"


def _path_panel(ax, flight: FaultFlight) -> None:
    """The COM's path, before (blue) and after (orange) the failure; a hover in cm about home."""
    run = flight.run
    hover = flight.flight == "hover"
    scale, unit = (100.0, "cm") if hover else (1.0, "m")
    origin = run.desired[0] if hover else np.zeros(3)
    d = (run.desired - origin) * scale
    f = (run.flown - origin) * scale
    after = flight.after
    if hover:
        ax.scatter(*d[0], color="0.3", marker="+", s=80, label="home (desired)")
    else:
        ax.plot(*d.T, "--", color="0.45", lw=1.3, label="desired")
    k = int(np.argmax(after)) if after.any() else len(f)
    ax.plot(*f[: k + 1].T, color=BEFORE, lw=1.4, label="flown before the failure")
    if after.any():
        ax.plot(*f[k:].T, color=AFTER, lw=1.4, label="flown after")
        ax.scatter(*f[k], color=FAILURE, marker="x", s=70, label="failure")
    pts = np.vstack([d, f])
    span = max(float(np.ptp(pts, axis=0).max()), 1.0 if hover else 0.2)
    centre = (pts.max(axis=0) + pts.min(axis=0)) / 2
    for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        set_lim(c - 0.55 * span, c + 0.55 * span)
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    ax.set_zlabel(f"z [{unit}]")
    ax.set_title("COM path" + (" about home" if hover else ""), fontsize=10)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.0), ncols=2, fontsize=8)  # under the box


def _error_panel(ax, t: np.ndarray, error_cm: np.ndarray, goal_cm: float) -> None:
    """Position error over time, the y-axis scaled to the data (at least MIN_SCALE_CM); the goal
    a dashed line where it lies within 3x that scale, else named in the legend."""
    finite = error_cm[np.isfinite(error_cm)]
    top = max(1.15 * float(finite.max(initial=0.0)), MIN_SCALE_CM)
    ax.plot(t, error_cm, color=BEFORE, lw=1, label="position error")
    if goal_cm <= 3.0 * top:
        ax.axhline(goal_cm, ls="--", color=FAILURE, lw=1, label=f"goal {goal_cm:g} cm")
        top = max(top, 1.15 * goal_cm)
    else:
        ax.plot([], [], ls="--", color=FAILURE, lw=1,
                label=f"goal {goal_cm:g} cm (above this scale)")  # fmt: skip
    ax.set_ylim(0.0, 1.15 * top)
    ax.legend(loc="best", fontsize=8)  # off the curve and the failure's lines and their words


def _mark_failed(ax, run, columns) -> None:
    """The failed rotors' inputs drawn thick and dashed (lines), or their rows marked (heat
    map)."""
    cols = list(columns)
    if run.inputs.shape[1] > MAX_LINES:  # a red frame round each run of failed rows
        runs = np.split(np.array(cols), np.flatnonzero(np.diff(cols) != 1) + 1)
        for i, rows in enumerate(runs):
            label = _failed_label(cols) if i == 0 else None
            ax.axhspan(rows[0] - 0.5, rows[-1] + 0.5, facecolor="none", edgecolor=FAILURE,
                       lw=1.0, label=label)  # fmt: skip
            ax.plot([0.0], [(rows[0] + rows[-1]) / 2], ">", color=FAILURE, ms=7, clip_on=False,
                    transform=ax.get_yaxis_transform())  # fmt: skip
        ax.legend(**OUTSIDE)  # beside the data, as inputs_panel's
        return
    for i, c in enumerate(cols):
        ax.plot(run.t, run.inputs[:, c], color=FAILURE, lw=2.2, ls="--",
                label=_failed_label(cols) if i == 0 else None)  # fmt: skip
    ax.legend(**OUTSIDE)  # beside the data, as inputs_panel's


def _failed_label(cols: list[int]) -> str:
    return f"failed rotor(s) {_list(cols)} (numbered from 1)"


def _list(cols: list[int]) -> str:
    """The failed columns numbered from 1, as the titles and the console number rotors."""
    return ", ".join(str(c + 1) for c in cols[:4]) + (", ..." if len(cols) > 4 else "")
