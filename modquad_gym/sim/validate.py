"""Validate a structure on a task in MuJoCo: wrench bench, hover, pictures and a short report.

:func:`validate` runs the wrench bench (:mod:`.bench`) with the exact allocation and with the
paper's ``clip(A^+ w, 0, f_max)``, then the hover (:mod:`.hover`), and, when given ``out_dir``,
writes there:

* ``rotor_inputs.png``: the bench's rotor inputs over time, each wrench held 500 ms as in the
  paper, f_max dotted (paper Fig. 7), one panel per allocation;
* ``bench_wrench.png``: measured against commanded wrench, per component;
* ``hover.png``: position and attitude error and rotor inputs over the hover (load known to the
  controller), f_max dotted;
* ``hover_unknown_load.png`` (``unknown_load=True``, the default): the same with the load unknown
  to the controller (load observer and integral action; the load ramps from one wrench to the
  next over ``load_ramp_seconds``);
* ``hover_infeasible.png`` (``include_infeasible_demo=True``): the same for a task wrench scaled
  out of the feasible set, which saturates the rotors and drifts;
* ``structure.png``: an offscreen MuJoCo render (EGL), or a matplotlib drawing where no GL context
  can be made;
* ``report.md``: the numbers; ``validation.json``: the returned dict.

Hover load convention: while the structure holds task wrench w, an external wrench
``d = -(w + gravity wrench)`` (gravity wrench = [m g ; 0] at the COM) is applied, so that at
equilibrium (level, in place) the rotors produce exactly the task wrench w; ``load_frame``
``"world"`` (default) keeps d fixed in the world, like gravity, ``"body"`` makes it follow the
body (see :mod:`modquad_gym.sim.hover.linearization`: a straight line then drifts in roll).

Two hovers are flown on the same wrenches: with the load known to the controller (feed-forward
``w``, which switches from one wrench to the next in a step; ``hover_*`` keys) and, with
``unknown_load``, with the load unknown (a load observer and integral action estimate it;
``hover_unknown_load_*`` keys), the honest test of the controller. In the unknown-load hover the
load ramps from one task wrench to the next over ``load_ramp_seconds`` at the start of each
segment (cosine profile), as a real task's load would, rather than stepping by several newtons
at once (see :mod:`modquad_gym.sim.hover.load`).

It returns a :class:`~modquad_gym.sim.report.ValidationReport` (``to_dict()``: the JSON record,
non-finite numbers as None).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is first imported: headless rendering

import math  # noqa: E402
from dataclasses import dataclass, replace  # noqa: E402
from functools import partial  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from modquad_gym.core.extras import require  # noqa: E402
from modquad_gym.core.validation import (  # noqa: E402
    check_f_max,  # noqa: E402
    check_flag,
    check_int,
)
from modquad_gym.geometry.structure import Structure  # noqa: E402
from modquad_gym.oracle import feasible, lambda_ratio, margin  # noqa: E402
from modquad_gym.oracle.scale import check_task_scale  # noqa: E402
from modquad_gym.sim.hover import HoverConfig, run_hover, unreachable_wrench_directions, wrench_axis  # noqa: E402
from modquad_gym.sim.hover.run import hover_bar  # noqa: E402
from modquad_gym.sim.hover_options import DEFAULT_HOVER_WRENCHES, checked_hover  # noqa: E402
from modquad_gym.sim.inertial import check_simulable  # noqa: E402
from modquad_gym.sim.model import build_model  # noqa: E402
from modquad_gym.sim.pictures import (  # noqa: E402
    plot_bench_wrench,
    plot_hover,
    plot_rotor_inputs,
    render_structure,
)
from modquad_gym.sim.report import (  # noqa: E402
    SEGMENT_KEYS,
    HoverSummary,
    InfeasibleDemo,
    ValidationReport,
    finite_or_none,
)
from modquad_gym.sim.report_markdown import markdown  # noqa: E402
from modquad_gym.sim.validation_files import REPORT_FILES, ReportPage, hold_out_dir  # noqa: E402
from modquad_gym.sim.wrench_stand import BenchResult, run_bench  # noqa: E402
from modquad_gym.tasks import as_task  # noqa: E402

INFEASIBLE_SCALE = 1.3
"""The infeasible demo scales a task wrench to this multiple of its feasibility boundary."""

SETTLE_FRACTION = 0.3
"""The hovers' errors are measured over the last 30 % of each segment (settled)."""


def infeasible_wrench(A: np.ndarray, w: np.ndarray, f_max: float, scale: float) -> np.ndarray:
    """``w`` rescaled to ``scale`` times the largest feasible multiple of its direction."""
    ratio = float(lambda_ratio(A, w[None], f_max)[0])  # lambda* / |w|: boundary at w * ratio
    if not math.isfinite(ratio) or ratio <= 0:
        return w * scale  # w = 0 or no positive multiple feasible: any scaling stays infeasible
    return w * ratio * scale


def hover_wrench_sample(margins: np.ndarray, k: int | None, seed: int = 0) -> np.ndarray:
    """Indices (in task order) of at most ``k`` wrenches to hover under: the half with the
    smallest margins (nearest the boundary: the hardest to hold), the rest drawn uniformly
    with ``seed`` from the others. All of them when ``k`` is None or not smaller."""
    t = len(margins)
    if k is None or k >= t:
        return np.arange(t)
    k = check_int(k, "max_hover_wrenches", low=1)
    hardest = np.argsort(margins, kind="stable")[: (k + 1) // 2]
    others = np.setdiff1d(np.arange(t), hardest)
    drawn = np.random.default_rng(seed).choice(others, size=k - len(hardest), replace=False)
    return np.sort(np.concatenate([hardest, drawn]))


def validate(structure: Structure, task: Any, f_max: float | None = None,
             out_dir: str | Path | None = None, hover_seconds: float = 2.0, render: bool = True,
             include_infeasible_demo: bool = False,
             max_hover_wrenches: int | None = DEFAULT_HOVER_WRENCHES, unknown_load: bool = True,
             load_frame: str = "world", load_ramp_seconds: float | None = None,
             kind: str | None = None, force: bool = False, progress: bool = False,
             command: str | None = None,
             page: ReportPage | None = None) -> ValidationReport:  # fmt: skip
    """Bench and hover ``structure`` on ``task_wrenches``; write pictures and a report.

    For a task of ``kind`` ``external`` the wrenches are those applied to the environment: the
    bench and the hover use the rotor wrenches ``w + m g e_z`` of the structure's own mass
    (:func:`modquad_gym.tasks.rotor_wrenches`; the model weighs each module by its type), so
    the hover's external load is exactly ``-w`` (the structure lifts its real weight). The
    hover's load convention and its two hovers (load known, load unknown) are described in the
    module docstring.

    Args:
        structure: the structure to validate (e.g. a search result's ``structure``).
        task: the task (anything :func:`~modquad_gym.tasks.as_task` takes: a task, a search
            problem, or (t, 6) wrenches in {S}); its rotor wrenches are what the structure's
            rotors must produce, its ``f_max`` and kind apply unless given here.
        f_max: rotor thrust limit in N (default the task's).
        out_dir: where to write the pictures, ``report.md`` and ``validation.json`` (None:
            nowhere); held for the call, before any simulation, as ``modquad validate --out``
            is (:func:`hold_out_dir`: files replaced only with ``force``; no second process).
        hover_seconds: simulated seconds per task wrench in the hover, 0.05 to 60.
        render: write ``structure.png`` (MuJoCo render, matplotlib fallback).
        include_infeasible_demo: also hover on the task wrench with the least margin, scaled to
            ``INFEASIBLE_SCALE`` times its feasibility boundary, to show saturation and drift.
        max_hover_wrenches: hover on at most this many task wrenches, chosen by
            :func:`hover_wrench_sample` (the hardest by margin, then a seeded sample, in task
            order; default 20, as ``modquad validate``); None: all.
        unknown_load: also fly the hover with the load unknown to the controller.
        load_frame: ``"world"`` or ``"body"``: how the hover's load moves when the body tilts.
        kind: the task kind, ``"total"`` or ``"external"`` (default the task's).
        load_ramp_seconds: unknown-load hover: seconds over which the load goes from one task
            wrench to the next, at most ``hover_seconds`` (None: 1; 0: a step). The settled part
            of a segment (its last 30 %) must come after the ramp, so the ramp is shortened to
            ``0.7 hover_seconds`` when the segments are shorter than ``load_ramp_seconds /
            0.7``; the ramp used is returned as ``hover_unknown_load_ramp_seconds``.
        progress: show a bar over the hovers' simulated seconds on stderr (``modquad
            validate`` does, unless ``--quiet``).
        command: the command that made the validation, named under ``report.md``'s title
            (``Made by `command`.``; ``modquad validate`` gives its own); None: no such line.
        page: with ``out_dir``, a :class:`~modquad_gym.sim.validation_files.ReportPage` that
            takes ``report.md``'s parts, for a caller that adds its sections and then writes it
            and ``validation.json``, each once; None: both written here.

    Returns:
        A :class:`~modquad_gym.sim.report.ValidationReport`; its ``to_dict()`` is the JSON
        record (``validation.json``, ``modquad validate --json``) with at least
        ``bench_max_error`` (relative, exact allocation),
        ``bench_max_error_pinv_clip``, ``bench_max_sensor_error``, ``hover_max_position_error_m``,
        ``hover_max_attitude_error_rad``, ``saturated_fraction`` (known-load hover),
        ``hover_unknown_load_max_position_error_m``, ``hover_unknown_load_max_attitude_error_rad``,
        ``hover_unknown_load_saturated_fraction``, ``hover_unknown_load_ramp_seconds`` (with
        ``unknown_load``), ``n_modules``,
        ``cells``, ``modules`` (type names), ``mass_kg``, ``task_kind``, ``rank``,
        ``unreachable_wrench_directions``, ``feasible`` (every wrench feasible per the oracle)
        and ``files``.
    """
    require("mujoco", *(["matplotlib"] if out_dir is not None else []))  # named, before any work
    hover_seconds, ramp, most = checked_hover(hover_seconds, load_ramp_seconds, max_hover_wrenches)
    progress = check_flag(progress, "progress")
    task, W, f_max = _checked(structure, task, f_max, kind, unknown_load, ramp)
    given = ReportPage.checked(page, out_dir)
    names = output_names(unknown_load, include_infeasible_demo, render)
    with hold_out_dir(out_dir, names, force) as out_dir:  # before any simulation
        A, feas, marg, sims, fields = _measure(structure, W, f_max, task.kind)
        config = HoverConfig(seconds_per_wrench=hover_seconds, load_frame=load_frame,
                             settle_fraction=SETTLE_FRACTION)  # fmt: skip
        flights = Flights(hover_wrench_sample(marg, most), ramp if unknown_load else None,
                          int(np.argmin(marg)) if include_infeasible_demo else None)  # fmt: skip
        report, runs = _fly(fields, sims[0], (A, W, f_max, feas), config, flights, progress)
        if out_dir is not None:
            text = (structure.to_text(), command)
            _write(out_dir, report, text, sims, runs, (render, force, given))
    return report


def _measure(structure: Structure, W: np.ndarray, f_max: float, kind: str) -> tuple:
    """(A, the rows' feasibility and margins, (the hover's model, the bench's runs with the
    exact allocation and with pinv + clip), the report's structure, task and bench fields)."""
    A = np.array(structure.configuration_matrix())
    feas = np.asarray(feasible(A, W, f_max), dtype=bool)
    marg = margin(A, W, f_max)
    exact, pinv = _bench(structure, W, f_max)
    fly_sim = build_model(structure, f_max, bench=False)
    fields = {**_structure_fields(structure, A, W, f_max, feas, marg, fly_sim.mass, kind),
              **_bench_fields(exact, pinv)}  # fmt: skip
    return A, feas, marg, (fly_sim, exact, pinv), fields


@dataclass(frozen=True)
class Flights:
    """The hovers :func:`validate` flies: under the task rows ``hovered`` with the load known,
    again with it unknown (ramped over ``ramp`` seconds; None: not flown), and the infeasible
    demo on row ``demo_row`` scaled out of the set (None: not flown)."""

    hovered: np.ndarray
    ramp: float | None
    demo_row: int | None

    def segments(self) -> list[int]:
        """Task segments of each flight (each flown after its take-off)."""
        k = len(self.hovered)
        return [k] + [k] * (self.ramp is not None) + [1] * (self.demo_row is not None)


def _fly(fields: dict, fly_sim, arrays: tuple, config: HoverConfig, flights: Flights,
         progress: bool) -> tuple[ValidationReport, dict]:  # fmt: skip
    """Fly ``flights`` (``arrays``: the task's A, rotor wrenches, f_max, feasibility), with a
    bar over their simulated seconds on stderr when ``progress``: (the report, ``fields`` and
    the hovers' summaries, {picture name: the flight's HoverResult or None})."""
    A, W, f_max, feas = arrays
    hovered, ramp = flights.hovered, flights.ramp
    W_hover = W[hovered]
    with hover_bar(progress, config, flights.segments()) as moved:
        hover = run_hover(fly_sim, W_hover, config, on_segment=moved)
        report = ValidationReport(**fields, **_hover_fields(hover, config, feas[hovered]))
        blind = None
        if ramp is not None:
            blind = _unknown_load_hover(report, fly_sim, W_hover, config, ramp, moved)
        demo = None
        if flights.demo_row is not None:
            demo = _infeasible_demo(report, fly_sim, A, W, flights.demo_row, f_max, config, moved)
    return report, {"hover": hover, "hover_unknown_load": blind, "hover_infeasible": demo}


def _checked(structure: Any, task: Any, f_max: float | None, kind: str | None,
             unknown_load: bool, load_ramp_seconds: float) -> tuple:  # fmt: skip
    """(the task with ``f_max`` and ``kind`` applied, its rotor wrenches on ``structure``, its
    f_max), each input checked first (ValueError naming what is wrong)."""
    if not isinstance(structure, Structure):
        raise ValueError(
            f"structure must be a modquad_gym.Structure, got {type(structure).__name__}"
        )
    check_simulable(structure)  # a module type MuJoCo cannot compile, before any work
    task = as_task(task).with_f_max(f_max).with_kind(kind)
    f_max = check_f_max(task.f_max)
    W = check_task_scale(task.rotor_wrenches(structure), f_max)  # the searches' and export's
    if unknown_load and not load_ramp_seconds >= 0:
        raise ValueError(f"load_ramp_seconds must be >= 0, got {load_ramp_seconds}")
    return task, W, f_max


def _hover_fields(hover, config: HoverConfig, feas: np.ndarray) -> dict:
    """The report's fields of the known-load hover on the wrenches whose feasibility is
    ``feas`` (those :func:`hover_wrench_sample` chose, in task order)."""
    return {
        "hover_load_frame": config.load_frame,
        "hover_seconds_per_wrench": config.seconds_per_wrench,
        "hover_wrenches": len(feas),
        "hover_n_feasible": int(feas.sum()),
        "hover": HoverSummary.of(hover),
        "hover_takeoff": next((s for s in hover.segment_metrics if s["segment"] == -1), None),
    }


def _unknown_load_hover(report: ValidationReport, fly_sim, W_hover, config, ramp: float,
                        moved=None):  # fmt: skip
    """Fly the hover with the load unknown to the controller (the load ramping over ``ramp``
    seconds, shortened to the part of a segment before its settled part); its summary goes into
    ``report``; ``moved``: :func:`run_hover`'s ``on_segment``."""
    ramp = min(float(ramp), (1.0 - SETTLE_FRACTION) * config.seconds_per_wrench)
    blind = run_hover(fly_sim, W_hover, replace(config, known_load=False, load_ramp_seconds=ramp),
                      on_segment=moved)  # fmt: skip
    report.unknown_load = HoverSummary.of(blind)
    report.unknown_load_ramp_seconds = ramp
    report.unknown_load_segments = [
        {k: s[k] for k in SEGMENT_KEYS} for s in blind.segment_metrics if s["segment"] >= 0
    ]
    return blind


def _infeasible_demo(report: ValidationReport, fly_sim, A, W, index: int, f_max: float, config,
                     moved=None):  # fmt: skip
    """Hover on task wrench ``index`` scaled out of the feasible set; into ``report``
    (``moved``: :func:`run_hover`'s ``on_segment``)."""
    w_bad = infeasible_wrench(A, W[index], f_max, INFEASIBLE_SCALE)
    demo = run_hover(fly_sim, w_bad[None], config, on_segment=moved)
    report.infeasible_demo = InfeasibleDemo.of(demo, w_bad, index)
    return demo


def _bench(structure: Structure, W: np.ndarray, f_max: float) -> tuple[BenchResult, BenchResult]:
    """The wrench bench with the exact allocation and with the paper's pinv + clip."""
    bench_sim = build_model(structure, f_max, bench=True)
    exact = run_bench(bench_sim, W, allocation="exact")
    return exact, run_bench(bench_sim, W, allocation="pinv_clip")


def _structure_fields(structure, A, W, f_max, feas, marg, mass, kind) -> dict:
    """The report's structure and task fields."""
    N = unreachable_wrench_directions(A)
    return {
        "n_modules": structure.n_modules,
        "cells": [list(c) for c in structure.cells],
        "modules": [m.name for m in structure.modules],
        "mass_kg": mass,
        "task_kind": kind,
        "rank": int(np.linalg.matrix_rank(A)),
        "unreachable_wrench_directions": [
            {"n": N[:, j].tolist(), **wrench_axis(N[:, j])} for j in range(N.shape[1])
        ],
        "f_max": f_max,
        "n_wrenches": len(W),
        "feasible": bool(feas.all()),
        "n_feasible": int(feas.sum()),
        "min_margin": finite_or_none(marg.min()),
        "module_mass_kg": mass / structure.n_modules,
    }


def _bench_fields(exact: BenchResult, pinv: BenchResult) -> dict:
    """The report's wrench-bench fields."""
    return {
        "bench_max_error": exact.max_error,
        "bench_max_error_pinv_clip": pinv.max_error,
        "bench_max_sensor_error": max(exact.max_sensor_error, pinv.max_sensor_error),
        "bench_pinv_clip_wrenches_missed": int(np.sum(pinv.relative_error > 1e-6)),
        "bench_exact_at_limit": int(exact.at_limit.sum()),
    }


_TITLES = {
    "hover": "hover, load known",
    "hover_unknown_load": "hover, load unknown",
    "hover_infeasible": "infeasible wrench",
}
"""The hovers' pictures (``NAME.png``) and their titles."""

BENCH_FILES = ("rotor_inputs.png", "bench_wrench.png")
RENDER_FILE = "structure.png"


def output_names(
    unknown_load: bool = True, include_infeasible_demo: bool = False, render: bool = True
) -> tuple[str, ...]:
    """The files :func:`validate` writes into ``out_dir`` with these options (what ``modquad
    validate`` refuses to replace without ``--force``, before any work): exactly the pictures
    :func:`_write` writes and the two files of :class:`ReportPage`."""
    hovers = {"hover": True, "hover_unknown_load": unknown_load,
              "hover_infeasible": include_infeasible_demo}  # fmt: skip
    return (
        *REPORT_FILES,
        *BENCH_FILES,
        *(f"{name}.png" for name, flown in hovers.items() if flown),
        *((RENDER_FILE,) if render else ()),
    )


def _write(d: Path, report, text: tuple, sims: tuple, runs: dict, options: tuple) -> None:
    """The pictures into ``d`` (paths in ``report.files``, with those of ``report.md`` and
    ``validation.json``); ``sims``: the hover's model and the bench's two results. The page
    (:func:`markdown`; ``text``: the structure's drawing and the command that made it, or None)
    goes into the caller's :class:`ReportPage` (``options``: render, force, that page), or,
    without one, is written here with ``validation.json``."""
    render, force, given = options
    fly_sim, exact, pinv = sims
    files = report.files
    for name, plot in zip(BENCH_FILES, (plot_rotor_inputs, plot_bench_wrench)):
        plot([exact, pinv], d / name)
        files[name.removesuffix(".png")] = str(d / name)
    for name, run in runs.items():
        if run is not None:
            plot_hover(run, d / f"{name}.png", title=_TITLES[name])
            files[name] = str(d / f"{name}.png")
    if render:
        report.render_backend = render_structure(fly_sim, d / RENDER_FILE)
        files["structure"] = str(d / RENDER_FILE)
    files["report"], files["json"] = (str(d / name) for name in REPORT_FILES)
    drawing, command = text
    compose = partial(markdown, report, drawing, runs["hover"], runs["hover_unknown_load"],
                      SETTLE_FRACTION, INFEASIBLE_SCALE, command)  # fmt: skip
    page = (ReportPage() if given is None else given).begin(d, force, compose)
    if given is None:
        page.write(report.to_dict())
