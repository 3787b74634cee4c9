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

Hover load convention: while the structure holds task wrench w, the external wrench
``d = -(w + gravity wrench)`` is applied at the COM, so that at equilibrium the rotors produce
exactly w (see :func:`validate` and :mod:`modquad_gym.sim.hover`).

It returns a JSON-serialisable dict (non-finite numbers become None).
"""

from __future__ import annotations

import os

from ..outputs import save_figure, write_text
from ..validation import check_int

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is first imported: headless rendering

import json
import math
from pathlib import Path

import numpy as np

from ..oracle import check_f_max, check_wrenches, feasible, lambda_ratio, margin
from ..structure import Structure
from ..tasks import rotor_wrenches
from .bench import BenchResult, run_bench
from .hover import HoverResult, run_hover, unreachable_wrench_directions, wrench_axis
from .model import HOME_HEIGHT, SimModel, build_model

BENCH_HOLD_S = 0.5
"""Seconds each wrench is held in the rotor-input plot (the paper commands one every 500 ms)."""

INFEASIBLE_SCALE = 1.3
"""The infeasible demo scales a task wrench to this multiple of its feasibility boundary."""

SETTLE_FRACTION = 0.3
"""The hovers' errors are measured over the last 30 % of each segment (settled)."""


def _num(x: float) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


# --------------------------------------------------------------------------------------------
# pictures
# --------------------------------------------------------------------------------------------
def render_structure(
    structure: Structure | SimModel,
    path: str | Path,
    width: int = 800,
    height: int = 600,
    backend: str = "auto",
) -> str:
    """Write a picture of the structure to ``path``; return the backend used.

    ``backend="auto"`` tries MuJoCo's offscreen renderer (``MUJOCO_GL``, EGL by default) and falls
    back to a matplotlib drawing when no GL context can be made; ``"mujoco"`` or ``"matplotlib"``
    force one.
    """
    if backend not in ("auto", "mujoco", "matplotlib"):
        raise ValueError(f"unknown backend {backend!r}; choose auto, mujoco or matplotlib")
    sim = structure if isinstance(structure, SimModel) else build_model(structure)
    if backend in ("auto", "mujoco"):
        try:
            _render_mujoco(sim, Path(path), width, height)
            return "mujoco"
        except Exception:
            if backend == "mujoco":
                raise
    _render_matplotlib(sim.structure, Path(path))
    return "matplotlib"


def _render_mujoco(sim: SimModel, path: Path, width: int, height: int) -> None:
    import mujoco

    data = sim.new_data()
    renderer = mujoco.Renderer(sim.model, height, width)
    try:
        cam = mujoco.MjvCamera()
        cam.lookat[:] = [0.0, 0.0, HOME_HEIGHT]
        cam.distance = 2.0 * float(sim.model.stat.extent) + 0.6
        cam.azimuth = 135.0
        cam.elevation = -35.0
        renderer.update_scene(data, camera=cam)
        img = renderer.render()
    finally:
        renderer.close()
    _plt().imsave(path, img)


def _render_matplotlib(structure: Structure, path: Path) -> None:
    plt = _plt()
    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    half = structure.side / 2
    mixed = structure.is_mixed
    for i, (c, t) in enumerate(zip(structure.module_centres, structure.type_indices)):
        xs = c[0] + np.array([-half, half, half, -half, -half])
        ys = c[1] + np.array([-half, -half, half, half, -half])
        colour = f"C{int(t)}" if mixed else "tab:green" if i == 0 else "0.4"
        ax.plot(xs, ys, np.zeros(5), color=colour)
    spins = structure.rotor_spins
    p, d = structure.rotor_positions, structure.rotor_directions
    for pk, dk, sk in zip(p, d, spins, strict=True):
        colour = "tab:red" if sk > 0 else "tab:blue"
        ax.quiver(*pk, *dk, length=0.12, color=colour, arrow_length_ratio=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"{structure.n_modules} modules (thrust axes; red/blue = spin)")
    lim = np.abs(p).max() + half
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_zlim(-lim / 2, lim / 2)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def plot_rotor_inputs(results: list[BenchResult], path: str | Path) -> None:
    """Paper Fig. 7: rotor inputs per commanded wrench (held 500 ms each), f_max dotted."""
    plt = _plt()
    fig, axes = plt.subplots(len(results), 1, figsize=(9, 3.2 * len(results)), squeeze=False)
    for ax, res in zip(axes[:, 0], results, strict=True):
        t = np.arange(len(res.u) + 1) * BENCH_HOLD_S
        u = np.vstack([res.u, res.u[-1:]])
        ax.step(t, u, where="post", lw=1.0)
        ax.axhline(res.f_max, ls=":", color="k", lw=1.5, label="f_max")
        ax.axhline(0.0, ls=":", color="0.5", lw=1.0)
        ax.set_ylim(-0.05 * res.f_max, 1.1 * res.f_max)
        ax.set_ylabel("rotor input [N]")
        n_lim = int(res.at_limit.sum())
        ax.set_title(f"{res.allocation}: {n_lim}/{len(res.u)} wrenches with a rotor at a limit")
        ax.legend(loc="upper right")
    axes[-1, 0].set_xlabel("time [s] (one task wrench every 500 ms)")
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def plot_bench_wrench(results: list[BenchResult], path: str | Path) -> None:
    """Measured (load cell) against commanded wrench, one panel per component."""
    plt = _plt()
    names = ["f_x [N]", "f_y [N]", "f_z [N]", "tau_x [Nm]", "tau_y [Nm]", "tau_z [Nm]"]
    fig, axes = plt.subplots(2, 3, figsize=(11, 6.5))
    markers = {"exact": "o", "pinv_clip": "x"}
    for j, ax in enumerate(axes.flat):
        lo = min(float(r.commanded[:, j].min()) for r in results)
        hi = max(float(r.commanded[:, j].max()) for r in results)
        ax.plot([lo, hi], [lo, hi], color="0.6", lw=1, label="measured = commanded")
        for res in results:
            ax.plot(
                res.commanded[:, j],
                res.measured[:, j],
                markers.get(res.allocation, "."),
                ms=4,
                fillstyle="none",
                label=f"{res.allocation} (max rel. err {res.max_error:.1e})",
            )
        ax.set_title(names[j])
        ax.set_xlabel("commanded")
        ax.set_ylabel("measured")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


def plot_hover(res: HoverResult, path: str | Path, title: str = "hover") -> None:
    """Position and attitude error (log scale) and rotor inputs over time, f_max dotted."""
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    floor = 1e-9
    axes[0].semilogy(res.time, np.maximum(res.position_error, floor), lw=1)
    axes[0].axhline(0.01, ls="--", color="tab:red", lw=1, label="1 cm")
    axes[0].set_ylabel("position error [m]")
    axes[0].legend(loc="upper right")
    axes[1].semilogy(res.time, np.maximum(res.attitude_error, floor), lw=1, color="tab:purple")
    axes[1].set_ylabel("attitude error [rad]")
    axes[2].plot(res.time, res.u, lw=0.8)
    axes[2].axhline(res.f_max, ls=":", color="k", lw=1.5, label="f_max")
    axes[2].axhline(0.0, ls=":", color="0.5", lw=1.0)
    axes[2].set_ylim(-0.05 * res.f_max, 1.1 * res.f_max)
    axes[2].set_ylabel("rotor input [N]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="upper right")
    starts = res.time[np.flatnonzero(np.diff(res.segment)) + 1] if len(res.time) else []
    for ax in axes:
        for t in starts:
            ax.axvline(t, color="0.85", lw=0.8, zorder=0)
    axes[0].set_title(
        f"{title}: saturated {100 * res.saturated_fraction:.1f}% of control steps, "
        f"{int(res.diverged.sum())} segment(s) diverged"
    )
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)


# --------------------------------------------------------------------------------------------
# the run
# --------------------------------------------------------------------------------------------
def infeasible_wrench(A: np.ndarray, w: np.ndarray, f_max: float, scale: float) -> np.ndarray:
    """``w`` rescaled to ``scale`` times the largest feasible multiple of its direction."""
    ratio = float(lambda_ratio(A, w[None], f_max)[0])  # lambda* / |w|: boundary at w * ratio
    if not math.isfinite(ratio) or ratio <= 0:
        return w * scale  # w = 0 or no positive multiple feasible: any scaling stays infeasible
    return w * ratio * scale


def _hover_summary(hover: HoverResult) -> dict:
    """The task-level numbers of one hover run (JSON-ready)."""
    task = [s for s in hover.segment_metrics if s["segment"] >= 0]
    return {
        "max_position_error_m": hover.max_position_error,
        "max_attitude_error_rad": hover.max_attitude_error,
        "saturated_fraction": hover.saturated_fraction,
        "settled_saturated_fraction": hover.settled_saturated_fraction,
        "diverged_segments": int(hover.diverged.sum()),
        "segments_within_1cm": int(sum(s["max_position_error_m"] <= 0.01 for s in task)),
        "controllers": sorted(
            {c for s in hover.segment_metrics for c in s["controller"].split("+")}
        ),
        "max_load_estimate_error": hover.max_load_estimate_error,
    }


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


def validate(
    structure: Structure,
    task_wrenches: np.ndarray,
    f_max: float = 1.0,
    out_dir: str | Path | None = None,
    hover_seconds: float = 2.0,
    render: bool = True,
    include_infeasible_demo: bool = False,
    max_hover_wrenches: int | None = None,
    unknown_load: bool = True,
    load_frame: str = "world",
    load_ramp_seconds: float = 1.0,
    kind: str = "total",
) -> dict:
    """Bench and hover ``structure`` on ``task_wrenches``; write pictures and a report.

    For a task of ``kind`` ``external`` the wrenches are those applied to the environment: the
    bench and the hover use the rotor wrenches ``w + m g e_z`` of the structure's own mass
    (:func:`modquad_gym.tasks.rotor_wrenches`; the model weighs each module by its type), so
    the hover's external load is exactly ``-w`` (the structure lifts its real weight).

    Hover load convention: while the structure holds task wrench w, an external wrench
    ``d = -(w + gravity wrench)`` (gravity wrench = [m g ; 0] at the COM) is applied, so that at
    equilibrium (level, in place) the rotors produce exactly the task wrench w; ``load_frame``
    ``"world"`` (default) keeps d fixed in the world, like gravity, ``"body"`` makes it follow the
    body (see :mod:`modquad_gym.sim.hover` for why a straight line then drifts in roll).

    Two hovers are flown on the same wrenches: with the load known to the controller
    (feed-forward ``w``, which switches from one wrench to the next in a step; ``hover_*`` keys)
    and, with ``unknown_load``, with the load unknown (a load observer and integral action
    estimate it; ``hover_unknown_load_*`` keys), the honest test of the controller. In the
    unknown-load hover the load ramps from one task wrench to the next over
    ``load_ramp_seconds`` at the start of each segment (cosine profile), as a real task's load
    would, rather than stepping by several newtons at once (see :mod:`modquad_gym.sim.hover`).

    Args:
        structure: the structure to validate (e.g. a search result's ``structure``).
        task_wrenches: (t, 6) task wrenches in {S}: the total the rotors must produce
            (``kind="total"``) or the wrench applied to the environment (``"external"``).
        f_max: rotor thrust limit in N.
        out_dir: where to write the pictures, ``report.md`` and ``validation.json`` (created);
            None writes nothing.
        hover_seconds: simulated seconds per task wrench in the hover.
        render: write ``structure.png`` (MuJoCo render, matplotlib fallback).
        include_infeasible_demo: also hover on the task wrench with the least margin, scaled to
            ``INFEASIBLE_SCALE`` times its feasibility boundary, to show saturation and drift.
        max_hover_wrenches: hover on at most this many task wrenches, chosen by
            :func:`hover_wrench_sample` (the hardest by margin, then a seeded sample, in task
            order); None: all.
        unknown_load: also fly the hover with the load unknown to the controller.
        load_frame: ``"world"`` or ``"body"``: how the hover's load moves when the body tilts.
        kind: the task kind, ``"total"`` or ``"external"``.
        load_ramp_seconds: unknown-load hover: seconds over which the load goes from one task
            wrench to the next (default 1; 0: a step). The settled part of a segment (its last
            30 %) must come after the ramp, so the ramp is shortened to ``0.7 hover_seconds``
            when the segments are shorter than ``load_ramp_seconds / 0.7``; the ramp used is
            returned as ``hover_unknown_load_ramp_seconds``.

    Returns:
        A JSON-serialisable dict with at least ``bench_max_error`` (relative, exact allocation),
        ``bench_max_error_pinv_clip``, ``bench_max_sensor_error``, ``hover_max_position_error_m``,
        ``hover_max_attitude_error_rad``, ``saturated_fraction`` (known-load hover),
        ``hover_unknown_load_max_position_error_m``, ``hover_unknown_load_max_attitude_error_rad``,
        ``hover_unknown_load_saturated_fraction``, ``hover_unknown_load_ramp_seconds`` (with
        ``unknown_load``), ``n_modules``,
        ``cells``, ``modules`` (type names), ``mass_kg``, ``task_kind``, ``rank``,
        ``unreachable_wrench_directions``, ``feasible`` (every wrench feasible per the oracle)
        and ``files``.
    """
    if not isinstance(structure, Structure):
        raise ValueError(
            f"structure must be a modquad_gym.Structure, got {type(structure).__name__}"
        )
    W = rotor_wrenches(check_wrenches(task_wrenches), kind, structure.mass)
    f_max = check_f_max(f_max)
    A = np.array(structure.configuration_matrix())
    feas = np.asarray(feasible(A, W, f_max), dtype=bool)
    marg = margin(A, W, f_max)

    bench_sim = build_model(structure, f_max, bench=True)
    exact = run_bench(bench_sim, W, allocation="exact")
    pinv = run_bench(bench_sim, W, allocation="pinv_clip")
    fly_sim = build_model(structure, f_max, bench=False)
    W_hover = W[hover_wrench_sample(marg, max_hover_wrenches)]
    hover_kw = {
        "seconds_per_wrench": hover_seconds,
        "load_frame": load_frame,
        "settle_fraction": SETTLE_FRACTION,
    }
    hover = run_hover(fly_sim, W_hover, **hover_kw)
    N = unreachable_wrench_directions(A)

    known = _hover_summary(hover)
    out: dict = {
        "n_modules": structure.n_modules,
        "cells": [list(c) for c in structure.cells],
        "modules": [m.name for m in structure.modules],
        "mass_kg": fly_sim.mass,
        "task_kind": kind,
        "rank": int(np.linalg.matrix_rank(A)),
        "unreachable_wrench_directions": [
            {"n": N[:, j].tolist(), **wrench_axis(N[:, j])} for j in range(N.shape[1])
        ],
        "f_max": f_max,
        "n_wrenches": len(W),
        "feasible": bool(feas.all()),
        "n_feasible": int(feas.sum()),
        "min_margin": _num(marg.min()),
        "module_mass_kg": fly_sim.mass / structure.n_modules,
        "bench_max_error": exact.max_error,
        "bench_max_error_pinv_clip": pinv.max_error,
        "bench_max_sensor_error": max(exact.max_sensor_error, pinv.max_sensor_error),
        "bench_pinv_clip_wrenches_missed": int(np.sum(pinv.relative_error > 1e-6)),
        "bench_exact_at_limit": int(exact.at_limit.sum()),
        "hover_load_frame": load_frame,
        "hover_seconds_per_wrench": hover_seconds,
        "hover_wrenches": len(W_hover),
        "hover_n_feasible": int(feas[: len(W_hover)].sum()),
        "hover_max_position_error_m": known["max_position_error_m"],
        "hover_max_attitude_error_rad": known["max_attitude_error_rad"],
        "saturated_fraction": known["saturated_fraction"],
        "hover_settled_saturated_fraction": known["settled_saturated_fraction"],
        "hover_diverged_segments": known["diverged_segments"],
        "hover_segments_within_1cm": known["segments_within_1cm"],
        "hover_controllers": known["controllers"],
        "hover_takeoff": next((s for s in hover.segment_metrics if s["segment"] == -1), None),
        "files": {},
    }
    blind = None
    if unknown_load:
        if not load_ramp_seconds >= 0:
            raise ValueError(f"load_ramp_seconds must be >= 0, got {load_ramp_seconds}")
        ramp = min(float(load_ramp_seconds), (1.0 - SETTLE_FRACTION) * hover_seconds)
        blind = run_hover(
            fly_sim,
            W_hover,
            known_load=False,
            load_ramp_seconds=ramp,
            **hover_kw,
        )
        out["hover_unknown_load_ramp_seconds"] = ramp
        summary = _hover_summary(blind)
        for key, value in summary.items():
            out[f"hover_unknown_load_{key}"] = value
        out["hover_unknown_load_segments"] = [
            {
                k: s[k]
                for k in (
                    "segment",
                    "gamma",
                    "step_headroom",
                    "max_position_error_m",
                    "max_attitude_error_rad",
                    "saturated_fraction",
                    "settled_saturated_fraction",
                    "load_estimate_error",
                    "diverged",
                    "stop_reason",
                )
            }
            for s in blind.segment_metrics
            if s["segment"] >= 0
        ]
    demo = None
    if include_infeasible_demo:
        worst = int(np.argmin(marg))
        w_bad = infeasible_wrench(A, W[worst], f_max, INFEASIBLE_SCALE)
        demo = run_hover(fly_sim, w_bad[None], **hover_kw)
        seg = demo.segment_metrics[-1]
        out["infeasible_demo"] = {
            "wrench": w_bad.tolist(),
            "from_task_row": worst,
            "feasible": bool(demo.feasible[0]),
            "gamma": _num(demo.gamma[0]),
            "saturated_fraction": demo.saturated_fraction,
            "max_position_error_m": demo.max_position_error,
            "max_attitude_error_rad": demo.max_attitude_error,
            "diverged": bool(demo.diverged[0]),
            "stop_reason": seg["stop_reason"],
            "stop_time_s": seg["stop_time_s"],
        }

    if out_dir is not None:
        d = Path(out_dir)
        d.mkdir(parents=True, exist_ok=True)
        files = out["files"]
        plot_rotor_inputs([exact, pinv], d / "rotor_inputs.png")
        files["rotor_inputs"] = str(d / "rotor_inputs.png")
        plot_bench_wrench([exact, pinv], d / "bench_wrench.png")
        files["bench_wrench"] = str(d / "bench_wrench.png")
        plot_hover(hover, d / "hover.png", title="hover, load known")
        files["hover"] = str(d / "hover.png")
        if blind is not None:
            plot_hover(blind, d / "hover_unknown_load.png", title="hover, load unknown")
            files["hover_unknown_load"] = str(d / "hover_unknown_load.png")
        if demo is not None:
            plot_hover(demo, d / "hover_infeasible.png", title="infeasible wrench")
            files["hover_infeasible"] = str(d / "hover_infeasible.png")
        if render:
            out["render_backend"] = render_structure(fly_sim, d / "structure.png")
            files["structure"] = str(d / "structure.png")
        files["report"] = str(d / "report.md")
        files["json"] = str(d / "validation.json")
        write_text(d / "report.md", _report(structure, out, hover, blind))
        write_text(d / "validation.json", json.dumps(out, indent=2) + "\n")
    return out


def _report(
    structure: Structure, out: dict, hover: HoverResult, blind: HoverResult | None = None
) -> str:
    def f(x: float | None, fmt: str = ".3g") -> str:
        return "n/a" if x is None else format(x, fmt)

    t, n_hover = out["n_wrenches"], out["hover_wrenches"]
    which = f"all {t} wrenches" if n_hover == t else f"first {n_hover} of {t} wrenches"
    lines = [
        f"# MuJoCo validation: {out['n_modules']} modules",
        "",
        "```",
        structure.to_text(),
        "```",
        "",
        f"cells {out['cells']}, rank(A) = {out['rank']}, f_max = {out['f_max']:g} N, "
        f"module mass {out['module_mass_kg']:g} kg (mean), total {out['mass_kg']:g} kg.",
        f"Task: {t} wrenches of kind {out['task_kind']}, {out['n_feasible']} feasible per the "
        f"oracle (smallest margin {f(out['min_margin'])})"
        + (
            "; the rotors produce each wrench plus the structure's weight, which is what the "
            "bench commands and the hover's rotors hold (its external load is -w)."
            if out["task_kind"] == "external"
            else "."
        ),
    ]
    for u in out["unreachable_wrench_directions"]:
        n = ", ".join(f"{x:.4f}" for x in u["n"])
        if u["axis"] is not None:
            where = (
                f"no rotor wrench has a moment about the axis along "
                f"({', '.join(f'{x:.3g}' for x in u['axis'])}) through "
                f"({', '.join(f'{x:.3g}' for x in u['point'])}) m"
                + (f" (pitch {u['pitch']:.3g} m)" if abs(u["pitch"]) > 1e-9 else "")
            )
        else:
            where = "no rotor force along " + ", ".join(f"{x:.3g}" for x in u["force_direction"])
        lines.append(f"Unreachable wrench direction n = ({n}) (n . A u = 0 for all u): {where}.")
    lines += [
        "",
        "## Wrench bench (free body, load cell at the COM welded to the wall; weight subtracted)",
        "",
        "| allocation | max relative error vs commanded |",
        "|---|---|",
        f"| exact (oracle) | {out['bench_max_error']:.2e} |",
        f"| pinv + clip (paper) | {out['bench_max_error_pinv_clip']:.2e} |",
        "",
        f"Load cell vs A u (sensor fidelity): {out['bench_max_sensor_error']:.2e}. "
        f"pinv + clip misses {out['bench_pinv_clip_wrenches_missed']} wrench(es) by more than "
        f"1e-6; the exact allocation has a rotor at a limit on {out['bench_exact_at_limit']}.",
        "",
        f"## Hover on the {which} (gravity on, load d = -(w + gravity wrench), "
        f"fixed in the {out['hover_load_frame']} frame; LQR + bounded allocation)",
        "",
        f"Each wrench is held {out['hover_seconds_per_wrench']:g} s; errors are measured over "
        f"the last {100 * SETTLE_FRACTION:g} % of each segment (settled). "
        f"{out['hover_n_feasible']} of the {n_hover} "
        f"wrenches are feasible. Controllers used: {', '.join(out['hover_controllers'])}.",
        "",
        "| load | max pos. err [cm] | max att. err [rad] | segments <= 1 cm | saturated steps "
        "(all / settled) | diverged | max load-estimate error |",
        "|---|---|---|---|---|---|---|",
        f"| known (feed-forward w) | {out['hover_max_position_error_m'] * 100:.3g} | "
        f"{out['hover_max_attitude_error_rad']:.3g} | {out['hover_segments_within_1cm']} / "
        f"{n_hover} | {100 * out['saturated_fraction']:.2f} % / "
        f"{100 * out['hover_settled_saturated_fraction']:.2f} % | "
        f"{out['hover_diverged_segments']} | n/a |",
    ]
    ramp = out.get("hover_unknown_load_ramp_seconds")
    if blind is not None:
        load_change = f"{ramp:g} s ramp" if ramp else "step"
        lines.append(
            f"| unknown (observer + integral, {load_change}) | "
            f"{out['hover_unknown_load_max_position_error_m'] * 100:.3g} | "
            f"{out['hover_unknown_load_max_attitude_error_rad']:.3g} | "
            f"{out['hover_unknown_load_segments_within_1cm']} / {n_hover} | "
            f"{100 * out['hover_unknown_load_saturated_fraction']:.2f} % / "
            f"{100 * out['hover_unknown_load_settled_saturated_fraction']:.2f} % | "
            f"{out['hover_unknown_load_diverged_segments']} | "
            f"{f(out['hover_unknown_load_max_load_estimate_error'])} |"
        )
    lines += [
        "",
        "With the load known the feed-forward equals the load and switches with it in a step, "
        "so a feasible wrench is held with no transient and the settled errors only show that "
        "the model is consistent.",
    ]
    if blind is not None:
        if ramp:
            change = (
                f"the load goes from one task wrench to the next over the first {ramp:g} s of "
                "each segment (a cosine ramp: no jump in the load or its rate), as a task's "
                "load builds up physically (a tool pressed, a payload taken up), rather than "
                "stepping by several newtons at once. The ramp stays inside the feasible set "
                "(it is convex): at every instant the load itself could be held by the rotors; "
                "what is tested is whether the controller follows a load it is not told about. "
                "The settled errors are measured after the ramp has ended"
            )
        else:
            change = (
                "each switch is a step of the load (load_ramp_seconds = 0), which no physical "
                "task does; it is the harshest test"
            )
        lines += [
            "",
            "With the load unknown the controller is told neither the wrenches nor when they "
            f"change: {change}. A load observer (rotor wrench sent minus the measured "
            "acceleration times the inertia, low-pass filtered) and integral action estimate "
            "the load. Braking after a change of load needs a wrench beyond w along the "
            "change (headroom below); where the feasible set has almost no room there, the "
            "transient saturates, and the faster the change the more likely the structure is "
            "pushed away. A diverged segment (cut at the drift limit, or ending over 0.1 m "
            "away) is followed by a restart at the hover equilibrium of its load, so it does "
            "not spill into the next segment's numbers.",
        ]
    lines += [
        "",
        "Take-off (from a few cm off and tilted, at half thrust; not in the task numbers): "
        + (
            f"settled position error {out['hover_takeoff']['max_position_error_m']:.2e} m."
            if out["hover_takeoff"]
            else "skipped."
        ),
        "",
    ]
    blind_seg = {s["segment"]: s for s in (blind.segment_metrics if blind is not None else [])}
    head = "| segment | gamma | known: pos. err [m] | att. err [rad] | saturated | diverged |"
    rule = "|---|---|---|---|---|---|"
    if blind is not None:
        head += " unknown: pos. err [m] | att. err [rad] | saturated | headroom | stopped |"
        rule += "---|---|---|---|---|"
    lines += [head, rule]
    for s in hover.segment_metrics[:41]:
        row = (
            f"| {'take-off' if s['segment'] < 0 else s['segment']} | {f(s['gamma'])} | "
            f"{s['max_position_error_m']:.2e} | "
            f"{s['max_attitude_error_rad']:.2e} | {100 * s['saturated_fraction']:.1f} % | "
            f"{s['stop_reason'] or 'no'} |"
        )
        b = blind_seg.get(s["segment"])
        if b is not None:
            row += (
                f" {b['max_position_error_m']:.2e} | {b['max_attitude_error_rad']:.2e} | "
                f"{100 * b['saturated_fraction']:.1f} % | {f(b['step_headroom'])} | "
                f"{b['stop_reason'] or 'no'} |"
            )
        lines.append(row)
    if len(hover.segment_metrics) > 41:
        lines.append(f"| ... | {len(hover.segment_metrics) - 41} more | | | | |")
    demo = out.get("infeasible_demo")
    if demo:
        if demo["diverged"] and demo["stop_time_s"] is None:
            ending = f"The run {demo['stop_reason']}."
        elif demo["diverged"]:
            ending = (
                f"The run was stopped after {demo['stop_time_s']:.3g} s because the "
                f"{demo['stop_reason']} (drift limit)."
            )
        else:
            ending = "The run did not reach a drift limit."
        lines += [
            "",
            "## Infeasible demo",
            "",
            f"Task row {demo['from_task_row']} scaled to {INFEASIBLE_SCALE:g} x its feasibility "
            f"boundary (gamma {f(demo['gamma'])}), load known: saturated "
            f"{100 * demo['saturated_fraction']:.1f} % of control steps; position error up to "
            f"{demo['max_position_error_m']:.3g} m and attitude error up to "
            f"{demo['max_attitude_error_rad']:.3g} rad. {ending}",
        ]
    pics = ("structure", "rotor_inputs", "bench_wrench", "hover", "hover_unknown_load")
    pics += ("hover_infeasible",)
    lines += ["", "## Pictures", ""]
    lines += [f"![{k}]({k}.png)" for k in pics if k in out["files"]]
    return "\n".join(lines) + "\n"
