"""``report.md`` of a MuJoCo validation: the structure, the bench, both hovers, per-segment
numbers, the infeasible demo and the pictures, written from a :class:`.report.ValidationReport`."""

from __future__ import annotations

from modquad_gym.sim.hover import HoverResult
from modquad_gym.sim.report import ValidationReport


def _f(x: float | None, fmt: str = ".3g") -> str:
    return "n/a" if x is None else format(x, fmt)


def _task_line(out: dict) -> str:
    """The headline of a static task: its wrenches, their kind, how many are feasible."""
    return (
        f"Task: {out['n_wrenches']} wrenches of kind {out['task_kind']}, {out['n_feasible']} "
        f"feasible per the oracle (smallest margin {_f(out['min_margin'])})"
        + (
            "; the rotors produce each wrench plus the structure's weight, which is what the "
            "bench commands and the hover's rotors hold (its external load is -w)."
            if out["task_kind"] == "external"
            else "."
        )
    )


def _structure_lines(text: str, out: dict, task_line: str | None = None) -> list[str]:
    lines = [
        f"# MuJoCo validation: {out['n_modules']} modules",
        "",
        "```",
        text,
        "```",
        "",
        f"cells {out['cells']}, rank(A) = {out['rank']}, f_max = {out['f_max']:g} N, "
        f"module mass {out['module_mass_kg']:g} kg (mean), total {out['mass_kg']:g} kg.",
        _task_line(out) if task_line is None else task_line,
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
    return lines


def _bench_lines(out: dict) -> list[str]:
    return [
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
    ]


def _hover_table(out: dict, settle_fraction: float, blind: bool) -> list[str]:
    t, n_hover = out["n_wrenches"], out["hover_wrenches"]
    which = (f"all {t} wrenches" if n_hover == t else f"{n_hover} of the {t} wrenches: the "
             "hardest half by margin and a seeded draw")  # fmt: skip
    lines = [
        "",
        f"## Hover on {which} (gravity on, load d = -(w + gravity wrench), "
        f"fixed in the {out['hover_load_frame']} frame; LQR + bounded allocation)",
        "",
        f"Each wrench is held {out['hover_seconds_per_wrench']:g} s; errors are measured over "
        f"the last {100 * settle_fraction:g} % of each segment (settled). "
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
    if blind:
        load_change = f"{ramp:g} s ramp" if ramp else "step"
        lines.append(
            f"| unknown (observer + integral, {load_change}) | "
            f"{out['hover_unknown_load_max_position_error_m'] * 100:.3g} | "
            f"{out['hover_unknown_load_max_attitude_error_rad']:.3g} | "
            f"{out['hover_unknown_load_segments_within_1cm']} / {n_hover} | "
            f"{100 * out['hover_unknown_load_saturated_fraction']:.2f} % / "
            f"{100 * out['hover_unknown_load_settled_saturated_fraction']:.2f} % | "
            f"{out['hover_unknown_load_diverged_segments']} | "
            f"{_f(out['hover_unknown_load_max_load_estimate_error'])} |"
        )
    return lines


def _hover_text(out: dict, blind: bool) -> list[str]:
    lines = [
        "",
        "With the load known the feed-forward equals the load and switches with it in a step, "
        "so a feasible wrench is held with no transient and the settled errors only show that "
        "the model is consistent.",
    ]
    ramp = out.get("hover_unknown_load_ramp_seconds")
    if blind:
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
    return lines


def _segment_table(hover: HoverResult, blind: HoverResult | None, rows: int = 41) -> list[str]:
    """One row per segment: take-off, then the task segments numbered from 1 (the hovered task
    wrenches in task order)."""
    blind_seg = {s["segment"]: s for s in (blind.segment_metrics if blind is not None else [])}
    head = "| segment | gamma | known: pos. err [m] | att. err [rad] | saturated | diverged |"
    rule = "|---|---|---|---|---|---|"
    if blind is not None:
        head += " unknown: pos. err [m] | att. err [rad] | saturated | headroom | stopped |"
        rule += "---|---|---|---|---|"
    lines = [head, rule]
    for s in hover.segment_metrics[:rows]:
        row = (
            f"| {'take-off' if s['segment'] < 0 else s['segment'] + 1} | {_f(s['gamma'])} | "
            f"{s['max_position_error_m']:.2e} | "
            f"{s['max_attitude_error_rad']:.2e} | {100 * s['saturated_fraction']:.1f} % | "
            f"{s['stop_reason'] or 'no'} |"
        )
        b = blind_seg.get(s["segment"])
        if b is not None:
            row += (
                f" {b['max_position_error_m']:.2e} | {b['max_attitude_error_rad']:.2e} | "
                f"{100 * b['saturated_fraction']:.1f} % | {_f(b['step_headroom'])} | "
                f"{b['stop_reason'] or 'no'} |"
            )
        lines.append(row)
    if len(hover.segment_metrics) > rows:
        lines.append(f"| ... | {len(hover.segment_metrics) - rows} more | | | | |")
    return lines


def _demo_lines(demo: dict | None, scale: float) -> list[str]:
    if not demo:
        return []
    if demo["diverged"] and demo["stop_time_s"] is None:
        ending = f"The run {demo['stop_reason']}."
    elif demo["diverged"]:
        ending = (
            f"The run was stopped after {demo['stop_time_s']:.3g} s because the "
            f"{demo['stop_reason']} (drift limit)."
        )
    else:
        ending = "The run did not reach a drift limit."
    return [
        "",
        "## Infeasible demo",
        "",
        f"Task row {demo['from_task_row'] + 1} scaled to {scale:g} x its feasibility "
        f"boundary (gamma {_f(demo['gamma'])}), load known: saturated "
        f"{100 * demo['saturated_fraction']:.1f} % of control steps; position error up to "
        f"{demo['max_position_error_m']:.3g} m and attitude error up to "
        f"{demo['max_attitude_error_rad']:.3g} rad. {ending}",
    ]


def markdown(
    report: ValidationReport,
    structure_text: str,
    hover: HoverResult,
    blind: HoverResult | None,
    settle_fraction: float,
    infeasible_scale: float,
    command: str | None = None,
    task_line: str | None = None,
) -> str:
    """``report.md``: the structure, the bench, both hovers, segments, demo and pictures; under
    the title the ``command`` that made it (none for None), as every report under results/;
    ``task_line`` in place of the task's headline (a dynamic task's: its rotor wrenches are a
    sample along the trajectory), None: the static task's."""
    out = report.to_dict()
    lines = _structure_lines(structure_text, out, task_line) + _bench_lines(out)
    if command is not None:
        lines[1:1] = ["", f"Made by `{command}`."]
    lines += _hover_table(out, settle_fraction, blind is not None)
    lines += _hover_text(out, blind is not None)
    lines += _segment_table(hover, blind)
    lines += _demo_lines(out.get("infeasible_demo"), infeasible_scale)
    pics = ("structure", "rotor_inputs", "bench_wrench", "hover", "hover_unknown_load")
    pics += ("hover_infeasible",)
    lines += ["", "## Pictures", ""]
    for k in (k for k in pics if k in out["files"]):
        lines += [f"![{k}]({k}.png)", *([STRUCTURE_CAPTION, ""] if k == "structure" else [])]
    return "\n".join(lines) + "\n"


STRUCTURE_CAPTION = (
    "*structure.png: the first module (the first of the cells) green and the others grey, or "
    "with several module types each type's colour; each rotor a disc across its thrust axis (an "
    "arrow along it where matplotlib draws the picture), blue for spin +1 and orange for spin -1 "
    "(the sign of its drag torque), the colours of `modquad show` (the module fills deepened "
    "so that MuJoCo's lighting keeps them apart).*"
)
"""The legend of the structure's picture (the colours of :mod:`modquad_gym.sim.model`, those of
every picture: :data:`modquad_gym.viz.raster.SPIN_COLOURS`)."""
