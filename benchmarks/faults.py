"""The price of fault tolerance: how many more modules a structure needs to keep doing its task
after a failure, with thrust to spare for a late detection, and how it flies through it.

    python -m benchmarks.faults --fly --out results/faults

For the first ``--per-suite`` tasks of each suite of ``--suites`` (the fault tier's suite and
the held-out paper-like, planted and dynamic suites; none of them seen by the margin's
calibration, benchmarks/fault_delay.py), the default search's minimum for each design of
:data:`DESIGNS`: intact; surviving any rotor, any module, any two rotors; surviving a rotor or
a module with the margin :func:`~modquad_gym.oracle.fault_delay.margin_for_delay` derives from
a 20 ms and a 50 ms detection delay. Each answer is re-verified (HiGHS on every failed matrix for
one failure) and timed. ``--fly`` flies each fault design through its worst failure in MuJoCo
with the controller told 20 ms and 50 ms late, and with the in-flight detector told nothing
(:class:`~modquad_gym.sim.detector.FailureDetector`, default sensor noise), and hovers each 60 s
intact with the detector on (false alarms). The oracle section times ``tolerates`` against
``feasible`` on a 7-module structure, one core. Writes report.md, faults.csv, oracle.csv and
price.png (extra modules against the delay designed for) into ``--out``.

A full run takes longer than one sitting: ``--update`` replaces only the rows (suite, task,
design) it makes and keeps the others of faults.csv (each row names the command that made it);
``--skip`` continues a suite where an earlier run stopped.
"""

from __future__ import annotations

import argparse
import csv
import fcntl
import shlex
import sys
import time
from pathlib import Path

import numpy as np

import modquad_gym as mq
from benchmarks.common import add_force, load_average, run_main
from modquad_gym.core.outputs import OutputError, check_output_dir
from modquad_gym.oracle.fault_delay import margin_for_delay
from modquad_gym.scoring import machine_description
from modquad_gym.tasks.suites import load_suite

SUITES = ("fault_rotor", "heldout_paper", "heldout_planted", "dynamic_motions")
SUITES_DIR = Path(mq.__file__).parent / "data" / "suites"
DESIGNS = {  # name: (fault, detection delay designed for in s)
    "intact": (None, 0.0), "rotor": ("rotor", 0.0), "rotor_20ms": ("rotor", 0.02),
    "rotor_50ms": ("rotor", 0.05), "module": ("module", 0.0), "module_20ms": ("module", 0.02),
    "module_50ms": ("module", 0.05), "rotor2": ("rotor2", 0.0),
}  # fmt: skip
FLOWN = ("20ms", "50ms", "detector")
"""How each fault design is flown: told of the failure 20 ms or 50 ms late, or by the detector."""
OUTPUTS = ("report.md", "faults.csv", "oracle.csv", "price.png")
GOAL_CM = 5.0


def design(task, name: str, n_max: int, time_limit: float) -> dict:
    """The default search's answer for one design of ``task``, re-verified, with its time."""
    fault, delay = DESIGNS[name]
    mu = margin_for_delay(delay, fault) if delay else None
    t0 = time.perf_counter()
    r = mq.anytime_search(task, n_max=n_max, time_limit=time_limit, fault=fault, fault_margin=mu)
    row = {"design": name, "fault": fault or "", "delay_ms": round(1000 * delay),
           "required_margin": round(mu or 0.0, 4), "modules": r.n_modules,
           "lower_bound": r.lower_bound, "certified": r.certified, "status": r.status.value,
           "n_max": n_max,
           "seconds": round(time.perf_counter() - t0, 2), "worst_fault_margin": None,
           "_structure": r.structure}  # fmt: skip
    if r.structure is not None and fault:
        W = task.rotor_wrenches(r.structure)
        if fault != "rotor2":  # HiGHS on every failed matrix (a pair's LPs are too many)
            ok = mq.tolerates(r.structure, W, task.f_max, fault=fault, method="scipy")
            assert ok.all(), f"{task.name} {name}: HiGHS rejects the answer"
        worst = float(mq.fault_margin(r.structure, W, task.f_max, fault=fault).min())
        assert worst >= (mu or 0.0) - 1e-6, f"{task.name} {name}: margin {worst} below {mu}"
        row["worst_fault_margin"] = round(worst, 5)
    return row


def forces_rule_out(task, fault: str, mu: float, n_max: int) -> bool:
    """True when the task's forces alone prove that no structure of up to ``n_max`` T-modules
    keeps the margin ``mu`` after every failure of kind ``fault``. A structure's force set
    depends only on how many rotors of each of a module's four directions still work (not on
    the shape): with counts c_j the rotors of direction j sum to U_j in [c_j mu f/2, c_j (1 -
    mu/2) f], and the force must be D U (an LP per wrench; the rotor wrenches of a line of n
    modules stand for every n-module structure, their forces being the same)."""
    from scipy.optimize import linprog

    D = mq.Structure([(0, 0)]).configuration_matrix()[:3]
    f = task.f_max
    for n in range(1, n_max + 1):
        forces = np.asarray(task.rotor_wrenches(mq.Structure([(i, 0) for i in range(n)])))[:, :3]
        counts = [np.full(4, n - 1)] if fault == "module" else [n - np.eye(4, dtype=int)[j]
                                                                 for j in range(4)]  # fmt: skip
        if all(linprog(np.zeros(4), A_eq=D, b_eq=w, method="highs",
                       bounds=[(c * mu * f / 2, c * (1 - mu / 2) * f) for c in cs]).status == 0
               for cs in counts for w in forces):  # fmt: skip
            return False  # this size is not ruled out
    return True


def explain_missing(rows: list[dict]) -> None:
    """``forces_rule_out`` for each margin design no search found (where not yet decided)."""
    tasks = {}
    for r in rows:
        if r["delay_ms"] and r["modules"] is None and r.get("forces_rule_out") is None:
            if r["suite"] not in tasks:
                tasks[r["suite"]] = {
                    t.name: t for t in load_suite(SUITES_DIR / f"{r['suite']}.json")
                }
            task = tasks[r["suite"]][r["task"]]
            r["forces_rule_out"] = forces_rule_out(
                task, r["fault"], r["required_margin"], r["n_max"]
            )


def fly(task, structure, fault: str, intact_seconds: float) -> dict:
    """Flights of one design through its worst failure (20 ms, 50 ms, the detector) and its
    intact hover with the detector on."""
    from modquad_gym.sim import fault_flight as ff
    from modquad_gym.sim.detector import DetectorConfig
    from modquad_gym.sim.failure import Failure

    out = {}
    for delay in (0.02, 0.05):
        f = ff.fly_with_failure(structure, task, fault, detection_delay_s=delay)
        out[f"error_cm_{1000 * delay:.0f}ms"] = round(100 * f.max_position_error_m, 3)
    f = ff.fly_with_failure(structure, task, fault, detector=DetectorConfig())
    after = f.summary()["fault_detected_after_s"]
    out["error_cm_detector"] = round(100 * f.max_position_error_m, 3)
    out["detected_ms"] = None if after is None else round(1000 * after, 1)
    out["isolated"] = f.summary()["fault_detected_rotors"] == [int(c) for c in f.worst.columns]
    w = np.asarray(task.rotor_wrenches(structure))[f.worst.row]
    never = Failure((0,), 1e9, 0.0, fault)
    calm = ff.hover_with_failure(structure, w, never, intact_seconds, task.f_max,
                                 detector=DetectorConfig())  # fmt: skip
    out["false_alarm"] = calm.detection is not None
    return out


def price(args, command: str) -> list[dict]:
    """One row per (suite, task, design) of this run."""
    rows = []
    for suite in args.suites:
        for task in load_suite(SUITES_DIR / f"{suite}.json")[args.skip : args.per_suite]:
            flown: dict = {}  # a structure flown once per fault kind
            for name in args.designs:
                limit = args.rotor2_time_limit if name == "rotor2" else args.time_limit
                row = {"suite": suite, "task": task.name,
                       **design(task, name, args.n_max, limit)}  # fmt: skip
                s = row.pop("_structure")
                if args.fly and s is not None and row["fault"]:
                    key = (s.cells, row["fault"])
                    if key not in flown:
                        flown[key] = fly(task, s, row["fault"], args.intact_seconds)
                    row.update(flown[key])
                row["command"] = command
                rows.append(row)
                print(f"{suite} {task.name} {name}: {row['modules']} (bound {row['lower_bound']}, "
                      f"{row['seconds']:.1f} s) {row.get('error_cm_detector', '')}",
                      file=sys.stderr)  # fmt: skip
    return rows


def oracle_speed(sizes=(10, 100, 1000, 10000), repeats: int = 5) -> list[dict]:
    """Wrenches decided per second by ``tolerates`` (each fault) and by ``feasible`` (best of
    ``repeats``), 7 modules (m = 28), wrenches drawn inside W (30-100 % of random allocations)."""
    s = mq.Structure([(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (2, 1), (0, 2)])
    A = s.configuration_matrix()
    rng = np.random.default_rng(0)
    rows = []
    for t in sizes:
        W = (rng.uniform(0, 1, (t, A.shape[1])) @ A.T) * rng.uniform(0.3, 1.0, (t, 1))
        rate = {}
        for name in ("feasible", "rotor", "module", "rotor2"):
            best = np.inf
            for k in range(repeats + 1):  # the first run warms compiled code and caches
                t0 = time.perf_counter()
                mq.feasible(A, W) if name == "feasible" else mq.tolerates(s, W, fault=name)
                if k:
                    best = min(best, time.perf_counter() - t0)
            rate[name] = t / best
        rows.append({"wrenches": t, **{f"{k}_per_s": round(v) for k, v in rate.items()},
                     **{f"{k}_ratio": round(rate[k] / rate["feasible"], 4)
                        for k in ("rotor", "module", "rotor2")}})  # fmt: skip
    return rows


def read_rows(path: Path) -> list[dict]:
    """The rows of an earlier csv, numbers and booleans restored."""

    def value(text: str):
        if text in ("True", "False"):
            return text == "True"
        for kind in (int, float):
            try:
                return kind(text)
            except ValueError:
                pass
        return None if text == "" else text

    if not path.is_file():
        return []
    with path.open(newline="") as fh:
        return [{k: value(v) for k, v in row.items()} for row in csv.DictReader(fh)]


def write_csv(path: Path, rows: list[dict]) -> None:
    keys: list[str] = []
    for row in rows:
        keys += [k for k in row if k not in keys]
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


def merged(old: list[dict], new: list[dict]) -> list[dict]:
    """``old`` without the (suite, task, design) rows ``new`` makes, then ``new``; in suite
    order."""
    made = {(r["suite"], r["task"], r["design"]) for r in new}
    rows = [r for r in old if (r["suite"], r["task"], r["design"]) not in made] + new
    order = {s: k for k, s in enumerate(SUITES)}
    tasks = {(r["suite"], r["task"]): k for k, r in enumerate(rows)}
    names = list(DESIGNS)
    return sorted(rows, key=lambda r: (order.get(r["suite"], 99), tasks[r["suite"], r["task"]],
                                       names.index(r["design"])))  # fmt: skip


def table(rows: list[dict]) -> dict:
    """{(suite, task): {design: row}}."""
    out: dict = {}
    for r in rows:
        out.setdefault((r["suite"], r["task"]), {})[r["design"]] = r
    return out


def extra(by_task: dict, suite: str, name: str) -> list[int]:
    """Extra modules of design ``name`` over the intact minimum, tasks of ``suite`` with both."""
    return [d[name]["modules"] - d["intact"]["modules"] for (s, _), d in by_task.items()
            if s == suite and name in d and "intact" in d and d[name]["modules"] is not None
            and d["intact"]["modules"] is not None]  # fmt: skip


def plot(path: Path, rows: list[dict]) -> None:
    """Mean extra modules over the intact minimum against the delay designed for, per suite."""
    import matplotlib.pyplot as plt

    by_task = table(rows)
    suites = [s for s in SUITES if any(r["suite"] == s for r in rows)]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.8), sharey=True)
    for ax, fault in zip(axes, ("rotor", "module")):
        for i, suite in enumerate(suites):
            ys, counts = [], []
            for name in (fault, f"{fault}_20ms", f"{fault}_50ms"):
                e = extra(by_task, suite, name)
                ys.append(np.mean(e) if e else np.nan)
                counts.append(len(e))
            n = sum(s == suite for s, _ in by_task)
            dodge = 1.2 * (i - (len(suites) - 1) / 2)  # ms: equal means stay apart
            label = f"{suite} ({', '.join(map(str, counts))} of {n})"  # tasks with a design
            ax.plot([x + dodge for x in (0, 20, 50)], ys, "o-", label=label)
        ax.set_title(f"any single {fault} failure, margin = rule(delay)")
        ax.set_xlabel("detection delay designed for (ms)")
        ax.set_xticks([0, 20, 50])
    axes[0].set_ylabel("extra modules over the intact minimum\n(mean over the tasks with a design)")
    for ax in axes:  # per suite: tasks with a design at 0, 20 and 50 ms, of the suite's
        ax.legend(
            frameon=False,
            fontsize=7,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.18),
            ncol=2,
            title="suite (tasks with a design at 0, 20, 50 ms)",
            title_fontsize=7,
        )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def fmean(xs) -> str:
    xs = [x for x in xs if x is not None]
    return f"{np.mean(xs):.2f}" if xs else "-"


def report(out: Path, rows: list[dict], speed: list[dict], args) -> None:
    by_task = table(rows)
    suites = [s for s in SUITES if any(r["suite"] == s for r in rows)]
    names = [n for n in DESIGNS if any(r["design"] == n for r in rows)]
    commands = list(dict.fromkeys(r["command"] for r in rows))
    mus = "; ".join(
        f"{r['fault']} {r['delay_ms']} ms: {r['required_margin']:g}"
        for r in {(r["fault"], r["delay_ms"], r["required_margin"]): r for r in rows
                  if r["delay_ms"]}.values()
    )  # fmt: skip
    lines = ["# The price of fault tolerance, and the margin a detection delay needs", "",
             f"Made on {machine_description()} by runs of one command, each making some rows "
             "of faults.csv (each row names its run; a later run replaces the rows it makes):",
             "", *[f"- `{c}`" for c in commands], "",
             "The runs shared the two cores with other work and with each other (up to five at a "
             "time): a search's wall-clock limit bought less search than on an idle machine "
             "(more answers uncertified, a few margin designs not found). Load average when "
             f"this page was written: {load_average()}.", "",
             "Per task, the default search's minimum (n_max and time limits in the commands; "
             "rotor2 has its own limit): intact; surviving any single rotor or module failure; "
             "the same with the margin the delay rule derives from a 20 ms and a 50 ms "
             f"detection delay (mu: {mus}); surviving any two rotor failures "
             "(rotor2). Every single-failure answer re-verified by HiGHS on each failed matrix.",
             "", "## Minimum structures per suite", "",
             "Mean modules over the tasks with an answer (tasks with an answer / tasks; "
             "certified).", "",
             "| suite | tasks | " + " | ".join(names) + " |",
             "|---|---|" + "---|" * len(names)]  # fmt: skip
    for suite in suites:
        ds = [d for (s, _), d in by_task.items() if s == suite]
        cells = []
        for n in names:
            rs = [d[n] for d in ds if n in d]
            found = [r for r in rs if r["modules"] is not None]
            cells.append(f"{fmean(r['modules'] for r in found)} ({len(found)}/{len(rs)}; "
                         f"{sum(r['certified'] for r in rs)})")  # fmt: skip
        lines.append(f"| {suite} | {len(ds)} | " + " | ".join(cells) + " |")
    lines += ["", "Extra modules over the intact minimum (mean, max; tasks with both answers):",
              "", "| suite | " + " | ".join(n for n in names if n != "intact") + " |",
              "|---|" + "---|" * (len(names) - 1)]  # fmt: skip
    for suite in suites:
        cells = [f"{fmean(e)}, {max(e, default='-')}" if (e := extra(by_task, suite, n)) else "-"
                 for n in names if n != "intact"]  # fmt: skip
        lines.append(f"| {suite} | " + " | ".join(cells) + " |")
    lines += ["", "![extra modules against the detection delay](price.png)", ""]
    missing: dict = {}
    for r in rows:
        if r["delay_ms"] and r["modules"] is None:
            missing.setdefault((r["task"], why_none(r)), []).append(r["design"])
    if missing:
        lines += ["No structure with the margin within the size limit: " + "; ".join(
            f"{task}, {', '.join(designs)} ({why})" for (task, why), designs in missing.items())
            + ".", ""]  # fmt: skip
    lines += seconds_section(rows, names) + flights_section(rows) + oracle_section(speed)
    lines += ["## Per task", "", "Modules (* not certified within the time limit; - none found).",
              "", "| suite | task | " + " | ".join(names) + " |",
              "|---|---|" + "---|" * len(names)]  # fmt: skip
    for (suite, task), d in by_task.items():
        cells = [
            ("-" if d[n]["modules"] is None else str(d[n]["modules"]))
            + ("" if d[n]["certified"] else "*")
            if n in d
            else ""
            for n in names
        ]
        lines.append(f"| {suite} | {task} | " + " | ".join(cells) + " |")
    lines += ["", "Data: faults.csv (one row per task and design, its flights), oracle.csv.", ""]
    (out / "report.md").write_text("\n".join(lines))


def why_none(row: dict) -> str:
    """Why a search gave no structure: proved (none of up to n_max) or not found in time."""
    if row.get("forces_rule_out"):
        return f"proved by the task's forces alone: none of up to {row['n_max']} modules"
    if row["status"] == "infeasible":
        return f"proved: none of up to {row['n_max']} modules"
    return f"none found in {row['seconds']:.0f} s; bound {row['lower_bound']}"


def seconds_section(rows: list[dict], names: list[str]) -> list[str]:
    lines = ["## Search time", "", "| design | searches | certified | seconds median | "
             "seconds max |", "|---|---|---|---|---|"]  # fmt: skip
    for n in names:
        rs = [r for r in rows if r["design"] == n]
        secs = [r["seconds"] for r in rs]
        lines.append(f"| {n} | {len(rs)} | {sum(r['certified'] for r in rs)} | "
                     f"{np.median(secs):.2f} | {max(secs):.2f} |")  # fmt: skip
    small = [r for r in rows if r["design"] == "rotor2" and any(
        i["design"] == "intact" and i["task"] == r["task"] and (i["modules"] or 99) <= 6
        for i in rows)]  # fmt: skip
    if small:
        ok = [r for r in small if r["certified"] and r["seconds"] <= 30]
        lines += ["", f"Goal (issue 47): a certified two-rotor minimum within 30 s for every task "
                  f"whose intact optimum is at most 6 modules: {len(ok)} of {len(small)} "
                  f"(slowest {max(r['seconds'] for r in small):.1f} s)."]  # fmt: skip
    return lines + [""]


def flights_section(rows: list[dict]) -> list[str]:
    flown = [r for r in rows if r.get("error_cm_detector") is not None]
    if not flown:
        return []
    lines = ["## Flown through the worst failure (MuJoCo)", "",
             "Each fault design flown through the failure that leaves it the smallest margin (a "
             "hover under the hardest wrench after it, or the dynamic task's trajectory), the "
             "controller told 20 ms or 50 ms late, or told nothing: the in-flight detector "
             "decides when and which rotors (modquad_gym.sim.detector, default sensor noise). "
             "Largest position error after the failure; within 5 cm / flown.", "",
             "| design | structures | 20 ms | 50 ms | detector | largest error (cm) at 20 ms, "
             "50 ms, detector |", "|---|---|---|---|---|---|"]  # fmt: skip
    for n in DESIGNS:
        rs = [r for r in flown if r["design"] == n]
        if rs:
            cols = [f"{sum(r[f'error_cm_{k}'] <= GOAL_CM for r in rs)}/{len(rs)}" for k in FLOWN]
            top = ", ".join(f"{max(r[f'error_cm_{k}'] for r in rs):.2f}" for k in FLOWN)
            lines.append(f"| {n} | {len(rs)} | " + " | ".join(cols) + f" | {top} |")
    goal = [r for r in flown if r["delay_ms"]]
    bad = [(r, k) for r in goal for k in ("detector", *[f"{d}ms" for d in (20, 50)
           if d <= r["delay_ms"]]) if r[f"error_cm_{k}"] > GOAL_CM]  # fmt: skip
    lines += ["", "Goal (issue 47): every design with the margin for a delay D within 5 cm when "
              "flown at D (and at 20 ms for the 50 ms designs) and with the detector: "
              + ("met" if not bad else "not met: " + ", ".join(
                  f"{r['task']} {r['design']} at {k} ({r[f'error_cm_{k}']:.1f} cm)"
                  for r, k in bad)) + f" ({len(goal)} designs)."]  # fmt: skip
    lines += ["", "### The detector", "",
              "| design | structures | detected | within 30 ms | ms median, max | right rotors | "
              "false alarms (intact hover) |", "|---|---|---|---|---|---|---|"]  # fmt: skip
    for n in DESIGNS:
        rs = [r for r in flown if r["design"] == n]
        if rs:
            ms = [r["detected_ms"] for r in rs if r["detected_ms"] is not None]
            lines.append(
                f"| {n} | {len(rs)} | {len(ms)} | {sum(m <= 30 for m in ms)} | "
                + (f"{np.median(ms):.1f}, {max(ms):.1f}" if ms else "-")
                + f" | {sum(r['isolated'] for r in rs)} | {sum(r['false_alarm'] for r in rs)} |"
            )
    quiet = [r for r in flown if r["detected_ms"] is None]
    if quiet:
        harmless = [r for r in quiet if r["error_cm_detector"] <= GOAL_CM]
        lost = [r for r in quiet if r["error_cm_detector"] > GOAL_CM]
        lines += ["", f"Never detected: {len(quiet)} flights. {len(harmless)} of them stayed "
                  "within 5 cm (mostly rotors commanded near zero thrust when they failed: their "
                  "loss leaves almost no residual, and almost no harm); "
                  + (f"{len(lost)} drifted beyond it: " + ", ".join(
                      f"{r['task']} {r['design']} ({r['error_cm_detector']:.1f} cm)" for r in lost)
                     if lost else "none drifted beyond it") + "."]  # fmt: skip
    return lines + [""]


def oracle_section(speed: list[dict]) -> list[str]:
    lines = ["## Deciding tolerance", "",
             "Wrenches decided per second (best of 5), 7-module structure (m = 28 rotors, 378 "
             "pairs), wrenches inside W, one process. Goals: one failure at least 20 % of "
             "`feasible`'s rate (issue 37), two rotors at least 5 % at 1,000 wrenches "
             "(issue 47).", "",
             "| wrenches | feasible / s | rotor / s | ratio | module / s | ratio | rotor2 / s | "
             "ratio |", "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in speed:
        lines.append(f"| {r['wrenches']} | {r['feasible_per_s']:,} | {r['rotor_per_s']:,} | "
                     f"{r['rotor_ratio']:.2f} | {r['module_per_s']:,} | {r['module_ratio']:.2f} "
                     f"| {r['rotor2_per_s']:,} | {r['rotor2_ratio']:.3f} |")  # fmt: skip
    return lines + [""]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.faults", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--suites", nargs="+", choices=SUITES, default=list(SUITES),
                        help="suites (default all four)")  # fmt: skip
    parser.add_argument("--per-suite", type=int, default=10, help="tasks per suite (default 10)")
    parser.add_argument(
        "--skip",
        type=int,
        default=0,
        help="leave out the first SKIP of them (a run that continues another)",
    )
    parser.add_argument("--designs", nargs="+", choices=list(DESIGNS), default=list(DESIGNS),
                        help="designs (default all)")  # fmt: skip
    parser.add_argument("--n-max", type=int, default=12, help="module budget (default 12)")
    parser.add_argument("--time-limit", type=float, default=10.0,
                        help="seconds per search (default 10)")  # fmt: skip
    parser.add_argument(
        "--rotor2-time-limit",
        type=float,
        default=30.0,
        help="seconds per two-rotor search (default 30: the issue's goal)",
    )
    parser.add_argument("--fly", action="store_true", help="fly the fault designs in MuJoCo")
    parser.add_argument(
        "--intact-seconds",
        type=float,
        default=60.0,
        help="seconds of the intact hover with the detector (default 60)",
    )
    parser.add_argument(
        "--update",
        action="store_true",
        help="keep the rows of faults.csv in --out that this run does not make",
    )
    parser.add_argument("--oracle-only", action="store_true",
                        help="measure only the oracle's speed again and rewrite the report from "
                        "the faults.csv already in --out")  # fmt: skip
    parser.add_argument("--out", type=Path, default=Path("results/faults"))
    add_force(parser)
    args = parser.parse_args(argv)
    limits = (args.time_limit, args.rotor2_time_limit)
    if (
        not 0 <= args.skip < args.per_suite
        or args.n_max < 1
        or not all(0 < t <= 3600 for t in limits)
    ):
        parser.error(
            "--n-max must be >= 1, --skip in [0, --per-suite), the time limits in (0, 3600]"
        )
    if not 0 < args.intact_seconds <= 3600:
        parser.error("--intact-seconds must lie in (0, 3600]")
    if args.oracle_only and args.fly:
        parser.error("--oracle-only rewrites the report from the rows in --out without "
                     "searching or flying; leave out --fly")  # fmt: skip
    if (args.oracle_only or args.update) and not (args.out / "faults.csv").is_file():
        parser.error(f"--{'oracle-only' if args.oracle_only else 'update'}: no faults.csv in "
                     f"{args.out} to keep rows from (run once without it)")  # fmt: skip
    try:
        check_output_dir(args.out, OUTPUTS, args.force)
    except OutputError as exc:
        parser.error(str(exc))
    args.out.mkdir(parents=True, exist_ok=True)
    command = shlex.join(["python", "-m", "benchmarks.faults", *(argv or sys.argv[1:])])
    new = [] if args.oracle_only else price(args, command)
    speed = oracle_speed()
    with open(args.out / "faults.csv", "a+") as lock:  # runs in parallel merge one at a time
        fcntl.flock(lock, fcntl.LOCK_EX)
        keep = args.update or args.oracle_only
        rows = merged(read_rows(args.out / "faults.csv") if keep else [], new)
        explain_missing(rows)
        write_csv(args.out / "faults.csv", rows)
        write_csv(args.out / "oracle.csv", speed)
        plot(args.out / "price.png", rows)
        report(args.out, rows, speed, args)
    print(f"wrote {args.out}/report.md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "faults"))
