"""Validate a structure on a dynamic task: the wrench bench and hovers of :func:`.validate.validate`
on a sample of the task's rotor wrenches, then a flight along the trajectory (:mod:`.track`).

The rotor wrenches of a dynamic task depend on the structure (its mass and inertia); the bench
and the hovers get those of this structure (kind ``total``): at most ``max_bench_wrenches`` of
them, the half with the smallest margins (nearest the boundary) and the rest evenly spaced in
time. The flight adds the ``track_*`` keys to the record (:meth:`TrackResult.summary`) and, with
``out_dir``, the pictures ``track_path.png`` (3D path desired vs flown, position error),
``track_inputs.png`` (rotor inputs over time, paper Fig. 8) and ``track.gif`` (an animation), and
to ``report.md`` its task headline and a section, composed with the validation's page and written
once (:class:`~modquad_gym.sim.validation_files.ReportPage`).
"""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np

from modquad_gym.core.outputs import json_ready
from modquad_gym.dynamics import DynamicTask, as_dynamic
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import margin
from modquad_gym.sim.report import finite_or_none
from modquad_gym.sim.track import TrackConfig, TrackResult, fly_trajectory
from modquad_gym.sim.validation_files import ReportPage

TRACK_FILES = ("track_path.png", "track_inputs.png", "track.gif")
"""The pictures of the flight."""


def bench_sample(W: np.ndarray, A: np.ndarray, f_max: float, k: int) -> np.ndarray:
    """Indices (sorted) of at most ``k`` rows of W: the half with the smallest margins and the
    rest evenly spaced over the others."""
    t = len(W)
    if t <= k:
        return np.arange(t)
    hardest = np.argsort(margin(A, W, f_max), kind="stable")[: (k + 1) // 2]
    rest = np.setdiff1d(np.arange(t), hardest)
    spaced = rest[np.linspace(0, len(rest) - 1, k - len(hardest)).round().astype(int)]
    return np.unique(np.concatenate([hardest, spaced]))


def validate_trajectory(
    structure: Structure,
    task: DynamicTask,
    out_dir: str | Path | None = None,
    max_bench_wrenches: int = 20,
    hover_seconds: float = 2.0,
    unknown_load: bool = True,
    render: bool = True,
    config: TrackConfig | None = None,
    force: bool = False,
    progress: bool = False,
    command: str | None = None,
    page: ReportPage | None = None,
) -> dict:
    """Bench, hover and fly ``structure`` on the dynamic ``task`` (module docstring); the JSON
    record of :func:`.validate.validate` (``task_kind`` ``"dynamic"``) plus the ``track_*``
    keys, ``mass_with_payload_kg`` and the pictures in ``files``. ``out_dir`` is held for the
    whole call as :func:`.validate.validate` holds it (with the flight's pictures), before any
    simulation; ``force`` replaces the files this call writes there; ``progress`` shows the
    hovers' bar on stderr and ``command`` names the command in ``report.md``, as
    :func:`.validate.validate`'s do; ``page`` (with ``out_dir``) takes ``report.md``'s parts,
    the flight's headline and section added, for the caller to write once with its record, as
    :func:`.validate.validate`'s ``page`` does (None: written here)."""
    door = importlib.import_module("modquad_gym.sim.validate")  # its functions, at the call

    task = as_dynamic(task)  # a ValueError naming the type of anything else
    given = ReportPage.checked(page, out_dir)
    pictures = TRACK_FILES if render else TRACK_FILES[:2]  # the animation is a render
    names = door.output_names(unknown_load, render=render) + pictures
    with door.hold_out_dir(out_dir, names, force) as out_dir:  # before any simulation
        page = ReportPage() if given is None and out_dir is not None else given
        W = task.rotor_wrenches(structure)
        A = np.array(structure.configuration_matrix())
        rows = bench_sample(W, A, task.f_max, max_bench_wrenches)
        report = door.validate(structure, W[rows], f_max=task.f_max, out_dir=out_dir,
                               hover_seconds=hover_seconds, render=render,
                               unknown_load=unknown_load, max_hover_wrenches=len(rows),
                               force=force, progress=progress, command=command,
                               page=page)  # fmt: skip
        flight = fly_trajectory(structure, task, config)
        record = report.to_dict()
        record["task_kind"] = "dynamic"
        record["bench_rows"] = [int(i) for i in rows]
        payload = task.payload.mass if task.payload is not None else 0.0
        record["mass_with_payload_kg"] = structure.mass + payload
        record["min_margin_trajectory"] = finite_or_none(margin(A, W, task.f_max).min())
        record["trajectory_samples"] = task.n_wrenches
        record = json_ready(record | flight.summary())
        if out_dir is not None:
            _write(out_dir, record, structure, task, flight, render, page)
            if given is None:
                page.write(record)
    return record


def _write(d: Path, record: dict, structure, task, flight: TrackResult, render: bool,
           page: ReportPage) -> None:  # fmt: skip
    """The flight's pictures into ``d`` (paths in ``record["files"]``), its headline and
    section into ``page``."""
    from modquad_gym.sim.model import build_model
    from modquad_gym.sim.track_pictures import animate_track, plot_track_inputs, plot_track_path

    files = record["files"]
    plot_track_path(flight, d / "track_path.png", title=task.name)
    plot_track_inputs(flight, d / "track_inputs.png", title=task.name)
    files["track_path"], files["track_inputs"] = (
        str(d / "track_path.png"),
        str(d / "track_inputs.png"),
    )
    if render:
        sim = build_model(structure, task.f_max, payload=task.payload)
        record["animation_backend"] = animate_track(sim, flight, d / "track.gif")
        files["track_animation"] = str(d / "track.gif")
    page.task_line = dynamic_task_line(record)
    page.sections.append(track_markdown(record, task))


def dynamic_task_line(record: dict) -> str:
    """The headline of ``report.md`` for a dynamic task: its rotor wrenches benched and hovered
    are a sample of those along the trajectory (one per sample)."""
    k, n = record["n_wrenches"], record["trajectory_samples"]
    which = (
        f"all {n} of its rotor wrenches"
        if k == n
        else f"{k} of its {n} rotor wrenches (the hardest half by margin, the rest evenly spaced)"
    )
    return (
        f"Task: dynamic, one rotor wrench per trajectory sample; {which} benched and hovered, "
        f"{record['n_feasible']} of them feasible per the oracle (smallest margin "
        f"{_margin(record['min_margin'])}; along the whole trajectory "
        f"{_margin(record['min_margin_trajectory'])})."
    )


def _margin(x: float | None) -> str:
    return "n/a" if x is None else f"{x:.3g}"


def track_markdown(record: dict, task: DynamicTask) -> str:
    """The flight's section of ``report.md``."""
    payload = (
        f", payload {task.payload.mass:g} kg at {list(task.payload.offset)} m"
        if task.payload
        else ""
    )
    lines = [
        "## Flight along the trajectory",
        "",
        f"Task {task.name!r}: {task.n_wrenches} samples over {task.trajectory.duration:.3g} s"
        f"{payload}{', exerted wrenches' if task.exerted is not None else ''}; the rotor wrenches "
        f"above are this structure's (mass {record['mass_kg']:.3g} kg, its inertia), sampled at "
        f"rows {record['bench_rows'][:8]}{'...' if len(record['bench_rows']) > 8 else ''}.",
        "Controller: feed-forward Newton-Euler wrench at the reference plus LQR feedback, "
        "bounded allocation 0 <= u <= f_max.",
        "",
        "| max position error | rms position error | max attitude error | saturated steps |",
        "|---|---|---|---|",
        f"| {100 * record['track_max_position_error_m']:.3g} cm "
        f"| {100 * record['track_rms_position_error_m']:.3g} cm "
        f"| {record['track_max_attitude_error_rad']:.3g} rad "
        f"| {100 * record['track_saturated_fraction']:.3g} % |",
        "",
    ]
    if record.get("track_diverged"):
        lines.append(f"The flight was stopped: {record['track_diverged']}.")
    for key in ("track_path", "track_inputs", "track_animation"):
        if key in record["files"]:
            lines.append(f"![{key}]({Path(record['files'][key]).name})")
    return "\n".join(lines) + "\n"
