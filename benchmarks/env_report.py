"""The env speed benchmark, the report: env_benchmark.md from the rows of :mod:`.env_measure`
(the default configuration beside one PPO update, the lookahead rows, the task families and
sizes against issue 5's goal, the encodings table), its load and command lines."""

from __future__ import annotations

import argparse
import os

from benchmarks.common import machine_description, markdown_table
from benchmarks.env_measure import DEFAULT_ID, PPO_RECIPE, TARGET
from benchmarks.env_scale import scale_section


def lookahead_section(rows: list[dict], steps: int) -> list[str]:
    """The report's lines for the lookahead rows."""
    exact = [r for r in rows if r["lookahead"] == repr("exact")]
    exact = [r for r in exact if r["top_k"] is None] + [r for r in exact if r["top_k"]]
    said = "; ".join(
        f"**{r['cpu_steps_per_s']:,.0f} steps per CPU second at n_max {r['n_max']}"
        + (f" with top_k {r['top_k']}" if r["top_k"] else " (every child)")
        + ", "
        f"{r['cpu_rate_over_off']:.3f} of the default's**"
        + (f" (goal {r['goal']})" if "goal" in r else "")
        for r in exact
    )
    return [
        "## Lookahead rows, resets counted",
        "",
        f"`gym.make({DEFAULT_ID!r}, lookahead=..., n_max=...)`, {steps} timed steps each (a "
        "tenth of them beyond n_max 7), random masked actions, resets inside the loop (beyond "
        "n_max 7: tasks planted in n_max / 4 to n_max modules). `cpu_rate_over_off`: steps per "
        "CPU second over the default's (off) at the same n_max, in this run. With "
        '`lookahead="exact"` every child of every state gets its exact share and clipped mean '
        "margin (what greedy ranks by); with `lookahead_top_k` (the shipped policy's "
        "observation) only the shortlist does: "
        f"{said}; the default (off) keeps its speed (the option costs nothing when off).",
        "",
        markdown_table(rows),
        "",
    ]


def verdict(rows: list[dict], machine: str) -> str:
    """One line: is the issue's goal (>= TARGET steps/s) met, for which rows, on which machine."""
    met = [f"{r['tasks']} t={r['t']}" for r in rows if r["goal"] == "met"]
    missed = [f"{r['tasks']} t={r['t']}" for r in rows if r["goal"] != "met"]
    if not missed:
        head = f"Goal ({TARGET:,.0f} steps/s): met for every row"
    elif not met:
        head = f"Goal ({TARGET:,.0f} steps/s): NOT met for any row"
    else:
        head = (
            f"Goal ({TARGET:,.0f} steps/s): met for {', '.join(met)}; "
            f"NOT met for {', '.join(missed)}"
        )
    return f"{head} (on {machine})."


def default_section(row: dict) -> list[str]:
    """The report's lines for the "resets counted" row and the PPO update beside it."""
    lines = [
        "## Default configuration, resets counted",
        "",
        f"`gym.make({DEFAULT_ID!r})` as a user gets it (default task source, Gymnasium's "
        "wrappers), random masked actions from `obs['action_mask']`, every reset inside the "
        "timed loop (`us_per_step` excludes resets, `us_per_reset` is their mean). "
        f"**{row['steps_per_s']:,.0f} steps/s: goal ({TARGET:,.0f}) {row['goal']}.** "
        f"`cpu_steps_per_s` counts this process's CPU time instead of wall time "
        f"({row['cpu_steps_per_s']:,.0f} steps/s; on a shared machine the two differ by the "
        "time other processes took). `oracle_fallback_wrenches`: wrenches that the env's "
        "compiled certificates (`oracle/kernels.py`) left to the exact LP "
        "(within the tolerance rule's GUARD of the boundary).",
        "",
    ]
    if "ppo_update_ms" in row:
        lines += [
            f"One MaskablePPO update (`.train()`, {PPO_RECIPE['n_epochs']} epochs of batches "
            f"of {PPO_RECIPE['batch_size']} on a {PPO_RECIPE['n_steps']}-step rollout, "
            f"net {PPO_RECIPE['net_arch']}, CPU) took {row['ppo_update_ms']:.0f} ms in the same "
            f"run; the {PPO_RECIPE['n_steps']} env steps of its rollout, at the rate above, "
            f"cost {row['env_ms_per_rollout']:.0f} ms: env / update = "
            f"{row['env_over_update']:.2f}.",
            "",
        ]
    return lines + [markdown_table([row]), ""]


def report(
    rows: list[dict],
    default: dict | None,
    scale: list[dict],
    args: argparse.Namespace,
    pinning: str,
    lookahead: list[dict] = (),
) -> str:
    machine = machine_description()
    note = f" ({args.machine_note})" if args.machine_note else ""
    lines = [
        "# ModQuadAssembly-v0 speed",
        "",
        f"Machine: {machine}{note}; one process, {pinning}; {load_line(args.load_start)}.",
        f"Command: `{command_line(args)}`",
        "",
    ]
    if default is not None:
        lines += default_section(default)
    if lookahead:
        lines += lookahead_section(lookahead, args.lookahead_steps)
    if rows:
        lines += [
            "## Per task family and size",
            "",
            "Random valid (masked) actions, a fresh task drawn every episode from the family "
            "with exactly t wrenches, unwrapped env (``gym.make`` adds Gymnasium's checker "
            "wrappers). `steps_per_s` is measured after a warm-up of the per-structure caches; "
            "`cold_steps_per_s` is the warm-up itself. `oracle_tests_per_step` counts wrenches "
            "sent to the exact oracle (the others are rejected by the support-function "
            "features).",
            "",
            f"Goal of issue 5: at least {TARGET:,.0f} steps/s in one process on one core with "
            "random masked actions and a fresh task every episode (column `goal`).",
            "",
            f"**{verdict(rows, machine)}**",
            "",
            markdown_table(rows),
            "",
        ]
    if scale:
        lines += scale_section(scale)
    return "\n".join(lines)


def load_average() -> tuple[float, float, float] | None:
    """The 1, 5 and 15 minute load averages (None where the platform has none)."""
    try:
        return os.getloadavg()
    except (AttributeError, OSError):
        return None


def load_line(start: tuple[float, float, float] | None) -> str:
    """The load averages at the start and at the end of the run, in words."""
    end = load_average()
    if start is None or end is None:
        return "load average not available"
    return f"load average {start[0]:.2f} at the start, {end[0]:.2f} at the end (1 min)"


def command_line(args: argparse.Namespace) -> str:
    """The command that reproduces the report."""
    parts = [
        f"python -m benchmarks.env --steps {args.steps} --warmup {args.warmup}",
        f"--seed {args.seed} --n-max {args.n_max} --default-steps {args.default_steps}",
        "--sizes " + " ".join(str(t) for t in args.sizes),
        "--scale " + " ".join(str(n) for n in args.scale),
        f"--scale-steps {args.scale_steps} --scale-warmup {args.scale_warmup}",
        f"--lookahead-steps {args.lookahead_steps}",
        "--lookahead-n-max " + " ".join(str(n) for n in args.lookahead_n_max),
    ]
    if args.no_ppo:
        parts.append("--no-ppo")
    if args.machine_note:
        parts.append(f"--machine-note {args.machine_note!r}")
    return " ".join(parts)


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("env_report"))
