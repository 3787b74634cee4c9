"""The page and the figure of ``python -m benchmarks.fault_delay``, from its flights: the fit of
the margin a detection delay needs, the control at delay 0, the flight that sets the fit, and the
rule (:func:`render`; ``--render`` writes them again from a flights.csv alone, flying nothing).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from benchmarks.common import load_average, machine_description, write_text
from modquad_gym.core.outputs import save_figure

CALIBRATION_SEED0 = 9_000_000
"""Seeds of the calibration's tasks (source k draws ``CALIBRATION_SEED0 + 1000 k + i``); the
suites use 1-8 million (modquad_gym.scoring.suites, modquad_gym.scoring.tiers)."""
FAULTS = ("rotor", "module")
SAFETY = 1.25
"""The rule's slope: the fit's times this, rounded up to 0.05 (few structures per delay)."""


def not_the_delays(flights: list[dict], fault: str) -> set:
    """The ``fault`` designs (task, required margin) whose flight with the failure known at once
    (D = 0, where flown) did not hold: what fails them is not the delay, so their flights say
    nothing of the margin a delay needs."""
    return {(r["task"], r["required_margin"]) for r in flights
            if r["fault"] == fault and r["delay_s"] == 0 and not r["within_5cm"]}  # fmt: skip


def fit(flights: list[dict], delays, fault: str, control: bool = True) -> tuple[dict, float | None]:
    """Per delay the largest worst margin of a ``fault`` flight that did not hold (0 when
    none), and the smallest slope c with c * D above every one of them (None: no ``fault``
    flight). With ``control``, the designs that did not hold at D = 0 are left out
    (:func:`not_the_delays`)."""
    void = not_the_delays(flights, fault) if control else set()
    needed = {}
    for d in delays:
        lost = [r["worst_fault_margin"] for r in flights
                if r["fault"] == fault and r["delay_s"] == d and not r["within_5cm"]
                and (r["task"], r["required_margin"]) not in void]  # fmt: skip
        needed[d] = max(lost, default=0.0)
    if not any(r["fault"] == fault for r in flights):
        return needed, None
    return needed, max((needed[d] / d for d in delays if d > 0), default=0.0)


def plot(path: Path, flights: list[dict], slopes: dict, delays) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(FAULTS), figsize=(10, 4), sharey=True)
    for ax, fault in zip(axes, FAULTS):
        for ok, mark, label in ((True, "o", "within 5 cm"), (False, "x", "beyond 5 cm")):
            pts = [(r["delay_s"], r["worst_fault_margin"]) for r in flights
                   if r["within_5cm"] == ok and r["fault"] == fault]  # fmt: skip
            if pts:
                x, y = np.array(pts).T
                ax.scatter(1000 * x, y, marker=mark, label=label, alpha=0.6)
        if slopes[fault] is not None:
            d = np.linspace(0, max(delays), 20)
            ax.plot(1000 * d, slopes[fault] * d, "k--", label=f"fit: mu = {slopes[fault]:.2f} D")
        ax.set_title(f"{fault} failure" + ("" if slopes[fault] is not None else " (no flights)"))
        ax.set_xlabel("detection delay D (ms)")
        if ax.get_legend_handles_labels()[0]:  # a fault with no flight has nothing to name
            ax.legend(fontsize=8)
    axes[0].set_ylabel("worst fault margin of the design")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def verdict_words() -> str:
    """How each flight was flown and judged, in words, from the constants the flights used."""
    from modquad_gym.sim import fault_verdict as v
    from modquad_gym.sim.fault_flight import FAULT_BEFORE_S, FAULT_SECONDS

    return (
        "Each design flies its smallest-margin failure only (`fly_with_failure(..., "
        'failure="worst")`; `modquad validate` flies every failure by default): a hover holds '
        f"{FAULT_BEFORE_S:g} s, the failure strikes and it flies {FAULT_SECONDS:g} s more; a "
        "trajectory flies to its end, then holds its last point (at rest) until "
        f"{FAULT_SECONDS:g} s after the failure and at least {2 * v.SETTLE_WINDOW_S:g} s after "
        "the end, so that the settling windows judge the hold. *Within 5 cm* is the flight's "
        "verdict (`modquad_gym.sim.fault_verdict`): never stopped, within "
        f"{100 * v.GOAL_M:g} cm from the failure on, and settled at its end (the last "
        f"{v.SETTLE_WINDOW_S:g} s window's largest error not above the window before's by more "
        f"than {100 * v.SETTLE_GROWTH:g} % + {1000 * v.SETTLE_FLOOR_M:g} mm, and a working rotor "
        "off its limits in the last window). *Not settled* counts the flights within 5 cm that "
        "the settling test alone failed (flights.csv, column why_not)."
    )


def control_lines(flights: list[dict], delays) -> list[str]:
    """Per fault, the designs left out of the fit (they fail with the failure known at once)
    and the fit with them, or that none is; one line when no delay 0 was flown."""
    if 0 not in delays:
        return ["No flight with the failure known at once (delay 0): every flight is fitted."]
    lines = []
    for fault in FAULTS:
        void = sorted(not_the_delays(flights, fault))
        designs = {(r["task"], r["required_margin"]) for r in flights if r["fault"] == fault}
        why = {(r["task"], r["required_margin"]): r["why_not"] for r in flights
               if r["fault"] == fault and r["delay_s"] == 0}  # fmt: skip
        which = (
            "designs" if len(why) == len(designs) else f"designs flown at D = 0 (of {len(designs)})"
        )
        if not designs:
            lines.append(f"- {fault}: no flights")
        elif not why:
            lines.append(f"- {fault}: no design flown at delay 0; every flight is fitted")
        elif not void:
            lines.append(f"- {fault}: all {len(why)} {which} hold with the failure known at "
                         "once; every flight is fitted")  # fmt: skip
        else:
            named = "; ".join(f"{t} margin {m:g} ({why[t, m] or 'beyond 5 cm'})" for t, m in void)
            with_them = fit(flights, delays, fault, control=False)[1]
            lines.append(f"- {fault}: {len(void)} of {len(why)} {which} do not hold with the "
                         f"failure known at once, left out of the fit: {named}; with them the "
                         f"fit would be {with_them:.3f} D")  # fmt: skip
    return [
        "A design that does not hold even with the failure known at once (delay 0) fails "
        "for another reason than the delay (a flight that never settles, or saturates, "
        "whatever the delay), so its flights are left out of the fit:",
        "",
        *lines,
    ]


def binding(flights: list[dict], delays, fault: str) -> str:
    """The flight that sets ``fault``'s fit (the largest margin per second of delay of a flight
    that did not hold) and the fit without it, and without its task: whether one flight, or one
    task, alone sets the rule."""
    void = not_the_delays(flights, fault)
    lost = [r for r in flights if r["fault"] == fault and not r["within_5cm"] and r["delay_s"] > 0
            and (r["task"], r["required_margin"]) not in void]  # fmt: skip
    if not lost:
        return ""
    top = max(lost, key=lambda r: r["worst_fault_margin"] / r["delay_s"])
    rest = fit([r for r in flights if r is not top], delays, fault)[1] or 0.0
    task = fit([r for r in flights if r["task"] != top["task"]], delays, fault)[1] or 0.0
    why = f", {top['why_not']}" if top.get("why_not") else ""
    return (f"; set by {top['task']} (margin {top['worst_fault_margin']:.4g}, {top['modules']} "
            f"modules) at {1000 * top['delay_s']:g} ms ({top['max_error_cm']:.2f} cm{why}); "
            f"without that flight the fit would be {rest:.3f} D, without that task's flights "
            f"{task:.3f} D")  # fmt: skip


def render(out: Path, flights: list[dict], rerender: str | None = None, page: str = "") -> str:
    """report.md and margin_rule.png of ``flights`` written into ``out``; the page's text. A
    re-rendering names its command ``rerender`` (:func:`made_by`; ``page``: the page it
    replaces)."""
    delays = sorted({r["delay_s"] for r in flights})
    fits = {fault: fit(flights, delays, fault) for fault in FAULTS}
    plot(out / "margin_rule.png", flights, {f: fits[f][1] for f in FAULTS}, delays)
    text = report(flights, fits, delays, made_by(flights, rerender, page))
    write_text(out / "report.md", text)
    return text


def made_by(flights: list[dict], rerender: str | None = None, page: str = "") -> str:
    """The page's line naming the commands that flew ``flights``, the machine and its load. A
    re-rendering (its command ``rerender``) keeps that line of the page it replaces (``page``)
    where it names them all, else says machine and load are not recorded; and names itself."""
    commands = ", then ".join(f"`{c}`" for c in dict.fromkeys(r["command"] for r in flights))
    if rerender is None:
        return (f"Made by {commands} on {machine_description()} (shared with other work: the "
                "searches' time limits bought less search; load average when this page was "
                f"written {load_average()}).")  # fmt: skip
    kept = next((ln for ln in page.splitlines() if ln.startswith("Made by ")), "")
    kept = kept.split(" Re-rendered from ")[0].replace(
        "when this page was", "when the flights' page was"
    )
    if not kept.startswith(f"Made by {commands} on "):
        kept = f"Made by {commands} (machine and load average not recorded: re-rendered)."
    return f"{kept} Re-rendered from its flights.csv, no flight flown again, by `{rerender}`."


def report(flights: list[dict], fits: dict, delays: list[float], made: str) -> str:
    """The report page: ``made`` (:func:`made_by`), how the flights were judged, the flights per
    fault and delay, the fit, the flight that sets it, and the rule (a fault with no flight,
    where no design was found within n_max, says so)."""
    sources = dict.fromkeys(r["task"].rsplit("-cal-", 1)[0] for r in flights)
    lines = [
        "# The fault margin a detection delay needs",
        "",
        made,
        "",
        f"{len({r['task'] for r in flights})} tasks drawn from the sources "
        f"{', '.join(sources)} with the calibration's own seeds ({CALIBRATION_SEED0:,} + "
        "1000 k + i, disjoint from every suite), faults rotor and module, designs for required "
        f"margins {sorted({r['required_margin'] for r in flights})} ({len(flights)} flights of "
        f"{len({(r['task'], r['fault'], r['required_margin']) for r in flights})} designs), each "
        f"flown through its smallest-margin failure at delays "
        f"{[f'{1000 * d:g} ms' for d in delays]}.",
        "",
        verdict_words(),
        "",
        "| fault | delay | flights | within 5 cm | not settled | largest worst margin fitted "
        "(not held) | largest error (cm) |",
        "|---|---|---|---|---|---|---|",
    ]
    for fault in FAULTS:
        for dl in delays:
            rs = [r for r in flights if r["delay_s"] == dl and r["fault"] == fault]
            worst = f"{max(r['max_error_cm'] for r in rs):.2f}" if rs else "-"
            needed = f"{fits[fault][0][dl]:.4f}" if rs else "-"
            unsettled = sum(str(r.get("why_not", "")).startswith("not settled") for r in rs)
            unsettled = unsettled if rs else "-"
            lines.append(f"| {fault} | {1000 * dl:g} ms | {len(rs)} | "
                         f"{sum(r['within_5cm'] for r in rs)} | {unsettled} | {needed} | "
                         f"{worst} |")  # fmt: skip
    lines += ["", *control_lines(flights, delays)]
    lines += ["", "Fit through the origin above every threshold, and the rule "
              f"(modquad_gym.oracle.fault_delay.DELAY_SLOPES: {SAFETY:g} times the fit, rounded "
              f"up to 0.05), for D up to {max(delays):g} s (the delays flown):", ""]  # fmt: skip
    for fault in FAULTS:
        slope = fits[fault][1]
        if slope is None:
            lines.append(f"- {fault}: no flights (no design within n_max), no fit")
            continue
        rule = np.ceil(round(SAFETY * slope / 0.05, 9)) * 0.05
        lines.append(f"- {fault}: fit mu = {slope:.3f} D, rule mu = {rule:.2f} D"
                     f"{binding(flights, delays, fault)}")  # fmt: skip
    return "\n".join([*lines, "", "![rule](margin_rule.png)", ""])


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("fault_delay_report"))
