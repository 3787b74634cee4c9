"""The leaderboard's pages in Markdown: the at-a-glance table, each tier's ranked table with its
footnotes and sources, the scale section, how the numbers are made and how to add an agent."""

from __future__ import annotations

import csv
from pathlib import Path

from benchmarks.leaderboard_entries import (
    BUDGET,
    COMMAND,
    RESCORED,
    RESULTS,
    ROOT,
    T3,
    Entry,
)
from benchmarks.leaderboard_text import how_made, how_to_add
from modquad_gym import __version__


def _pct(v: T3, interval: bool) -> str:
    if not interval or v[1] == v[2]:
        return f"{100 * v[0]:.1f} %"
    return f"{100 * v[0]:.1f} % [{100 * v[1]:.1f}, {100 * v[2]:.1f}]"


def _num(v: T3, interval: bool, fmt: str) -> str:
    if not interval or v[1] == v[2]:
        return format(v[0], fmt)
    return f"{format(v[0], fmt)} [{format(v[1], fmt)}, {format(v[2], fmt)}]"


def _label(e: Entry) -> str:
    if e.kind == "learned" and e.seeds:
        return f"{e.method} ({e.seeds} seeds)" if e.seeds > 1 else f"{e.method} (one run)"
    if e.kind == "outside":
        runs = f", {e.seeds} seed{'s' if e.seeds != 1 else ''}" if e.seeds else ""
        return f"**{e.method}** (outside{runs})"
    return e.method


def ranked(entries: list[Entry]) -> list[Entry]:
    """Scored entries by optimal share within the budget (then success, fewer seconds), then
    the unscored ones."""
    scored = [e for e in entries if not e.status]
    scored.sort(key=lambda e: (-e.budget[0], -e.optimal[0], e.seconds[0]))
    return scored + [e for e in entries if e.status]


def tier_table(entries: list[Entry]) -> list[str]:
    """One tier's methods ranked at the budget; every row with its task count and seeds."""
    head = (f"| rank | method | tasks | optimal within {BUDGET:g} s | success | optimal share | "
            "mean modules | configs / task | oracle calls / task | seconds / task |")  # fmt: skip
    lines = [head, "|---|---|---|---|---|---|---|---|---|---|"]
    rank = 0
    for e in ranked(entries):
        if e.status:
            lines.append(f"| - | {_label(e)} | - | {e.status} | | | | | | |")
            continue
        rank += 1
        ci = e.seeds > 1
        one = _one_run(e)
        mark = " †" if any(n.startswith("modules:") for n in e.notes) else ""
        modules = "-" if e.modules is None else f"{e.modules:.2f}{mark}"
        tasks = f"{e.tasks}" if e.tasks >= e.full else f"{e.tasks} of {e.full} (partial)"
        own = _own(e)
        lines.append(
            f"| {rank} | {_label(e)} | {tasks} | {_pct(e.budget, ci)}{one}{own} | "
            f"{_pct(e.success, ci)} | {_pct(e.optimal, ci)} | {modules} | "
            f"{_num(e.evaluated, ci, '.1f')} | {_num(e.oracle_calls, ci, ',.0f')}{one} | "
            f"{_num(e.seconds, ci, '.3f')}{own} |"
        )
    return lines


def _one_run(e: Entry) -> str:
    """`` ‡`` where an entry's share within the budget is the shipped model's one run (the
    five-seed data hold no per-task seconds), else ``""``."""
    return " ‡" if any(n.startswith("one run:") for n in e.notes) else ""


def _own(e: Entry) -> str:
    """`` §`` on an outside agent's time-based numbers (submitted, not measured here)."""
    return " §" if e.kind == "outside" else ""


SELF_REPORTED = (
    "§ Self-reported: an outside agent's seconds per task, and with them its share within "
    f"{BUDGET:g} s (the rank's measure), are the submitted ones, timed on the submitter's "
    "machine and not measured again here, nor are its configurations and oracle calls; only "
    "its cells are verified again. The other rows are measured by the commands that made "
    "their sources. Identical or hand-picked seeds cannot be detected."
)
"""The note under a table that holds an outside agent's row."""


def glance(entries: list[Entry], tiers: list[str]) -> list[str]:
    """Optimal share (and within the budget) of every method on every tier; a share within the
    budget that is not the row's own data (a learned method's one run beside its five-seed
    mean) is marked ‡ and explained under the table."""
    methods = list(dict.fromkeys(e.method for e in entries))
    by = {(e.tier, e.method): e for e in entries}
    lines = ["| method | " + " | ".join(f"`{t}`" for t in tiers) + " |",
             "|---|" + "---|" * len(tiers)]  # fmt: skip
    for method in methods:
        cells = []
        for t in tiers:
            e = by.get((t, method))
            if e is None:
                cells.append("-")
            elif e.status:
                cells.append(e.status.partition(":")[0])
            else:
                part = "" if e.tasks >= e.full else f", {e.tasks} of {e.full} tasks"
                part += ", one run" if e.kind == "learned" and e.seeds == 1 else ""
                cells.append(f"{100 * e.optimal[0]:.1f} % ({100 * e.budget[0]:.1f} %"
                             f"{_one_run(e)}{_own(e)} within {BUDGET:g} s{part})")  # fmt: skip
        first = next(e for e in entries if e.method == method)
        lines.append(f"| {_label(first)} | " + " | ".join(cells) + " |")
    if any(_one_run(e) for e in entries if e.tier in tiers):
        lines += ["", "‡ The shipped model's one run (the tier report), not the five seeds: the "
                  "five-seed data hold no per-task seconds, so the share within "
                  f"{BUDGET:g} s (the rank's measure) can differ from the five seeds' optimal "
                  "share beside it, and even exceed it. The one run is today's code; the five "
                  "seeds were scored earlier, some before the learned solvers' exact lookahead "
                  "became a shortlist of 8 children (each seeds report says when)."]  # fmt: skip
    if any(_own(e) for e in entries if e.tier in tiers and not e.status):
        lines += ["", SELF_REPORTED]
    return lines


SCALE_REPORTS = {"default recipe": "scale_seeds", "+ expert iteration": "scale_seeds_exit"}
"""The five-seed scale reports (``python -m benchmarks.scale_seeds``): the default recipe's seeds,
and the same seeds after expert iteration at 8-32 modules (the shipped ``ppo_scale``'s recipe)."""


def scale_section(results_prefix: str, results: Path = RESULTS) -> list[str]:
    """The learned designer at 16-64 modules beside greedy, per band, from the five-seed scale
    reports' summaries ([] when they are not there)."""
    files = {k: results / v / "report.csv" for k, v in SCALE_REPORTS.items()}
    read = {k: {r["band"]: r for r in csv.DictReader(f.read_text().splitlines())}
            for k, f in files.items() if f.is_file()}  # fmt: skip
    if not read:
        return []
    columns = {"ppo_solves_greedys_pct": "greedy's tasks ppo solves, %",
               "ppo_minus_greedy_modules": "modules above greedy",
               "ppo_over_greedy_seconds": "time / greedy's"}  # fmt: skip
    head = ["band"] + [f"{c} ({k})" for c in columns.values() for k in read]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for band in next(iter(read.values())):
        cells = [read[k].get(band, {}).get(c, "-") for c in columns for k in read]
        lines.append(f"| {band} | " + " | ".join(cells) + " |")
    sources = "; ".join(f"`{results_prefix}{v}/report.md`" for v in SCALE_REPORTS.values())
    return [
        "## At the field's sizes (16-64 modules)",
        "",
        "Single-pass `ppo` over five training seeds on the 36 held-out scale tasks (planted, "
        "mixed palette, heavy payload, low force with high torque; 12 per band), beside greedy "
        "with the same 30 s limit, which solves all of them: the share of greedy's tasks it "
        "solves, its modules above greedy's where both solve and its wall time over greedy's "
        "(mean over seeds, 95 % bootstrap interval). These seeds act with the policy alone "
        "(`fallback=0`): they were run before the single pass took greedy's choice where the "
        "policy is unsure, which the shipped model does from 16 modules "
        f"(`{results_prefix}prune/16-64/report.md`). Every method at 16-128 modules: "
        f"`{results_prefix}scale/report.md`.",
        "",
        *lines,
        "",
        f"Sources: {sources}.",
        "",
    ]


def page(entries: list[Entry], tiers: list[str], image: str, results_prefix: str) -> str:
    """The leaderboard in Markdown; ``image`` is the plot's path from the page (the anytime
    curves lie beside it), ``results_prefix`` the path of ``results/`` files as written in the
    text."""
    r = results_prefix
    text = page_intro(entries, tiers, image)
    for t in tiers:
        mine = [e for e in entries if e.tier == t]
        if mine:
            text += tier_section(t, mine, r)
    text += scale_section(r)
    text += how_made(r)
    text += how_to_add(r)
    return "\n".join(text)


def page_intro(entries: list[Entry], tiers: list[str], image: str) -> list[str]:
    """The page's head: what is ranked and how, the at-a-glance table and both plots."""
    curves_image = image.replace("leaderboard.png", "leaderboard_anytime.png")
    return [
        "# Leaderboard",
        "",
        f"Made by `{COMMAND}` with modquad_gym {__version__} from the committed reports (every "
        "number below is read from their data files; none is typed by hand). Add your own agent: "
        "[below](#add-your-own-agent).",
        "",
        f"Every method on the held-out suites of the {len(tiers)} benchmark tiers, against each "
        "task's certified optimum (the exhaustive search's minimum module count), **ranked at "
        f"a time budget of {BUDGET:g} s per task**: the share of tasks a method answers with "
        f"the optimal module count within {BUDGET:g} s of wall time (every method gets the same "
        "budget). Beside it: success (an answer of at most the tier's n_max modules that the "
        "exact LP oracle verifies), the optimal share without a time limit, mean modules over "
        "the tasks solved, configurations evaluated (structures whose feasibility was decided), "
        "oracle calls (wrench-structure tests) and seconds per task, and the number of tasks "
        "each row was scored on. Learned methods and outside agents with several seeds: mean "
        "over the seeds with the 95 % bootstrap interval over seeds in brackets; searches: one "
        "run.",
        "",
        "## At a glance",
        "",
        f"Optimal share per tier (in brackets: within {BUDGET:g} s per task, the rank's "
        "measure); learned methods: mean over five seeds, except where marked ‡:",
        "",
        "<!-- --8<-- [start:glance] -->",
        *glance(entries, tiers),
        "<!-- --8<-- [end:glance] -->",
        "",
        f"![optimal share against seconds per task, per tier]({image})",
        "",
        f"The share of tasks answered optimally within t seconds, against t ({BUDGET:g} s "
        "dotted): each method's one run, and the anytime search's best structure so far "
        "(dashed), which reaches the optimum before it has proved it:",
        "",
        f"![tasks answered optimally within a time budget, per tier]({curves_image})",
        "",
    ]


def tier_section(t: str, mine: list[Entry], r: str) -> list[str]:
    """One tier's section: what the tier is, its ranked table, its footnotes and sources
    (``r``: the path of ``results/`` as written in the text)."""
    from modquad_gym.scoring.tiers import get_tier

    tier = get_tier(t)
    types = f"module types {tier.modules}" if tier.modules else "one module type"
    tasks = max(e.full for e in mine if not e.status)
    fault = (f", `fault=\"{tier.fault}\"`: an answer counts only when it still exerts every "
             f"task wrench after any single {tier.fault} failure, and the optimum is the "
             "smallest such structure" if tier.fault else "")  # fmt: skip
    text = [
        f"## Tier `{t}`",
        "",
        f"`{tier.env_id}`, {types}, n_max {tier.n_max}{fault}; held-out suites "
        f"{', '.join(f'`{s}`' for s in tier.suites)}: {tasks} tasks whose certified optimum "
        f"is within n_max.{_models(tier, mine)}",
        "",
        *tier_table(mine),
        "",
        *tier_footnotes(mine, r),
        *([SELF_REPORTED, ""] if any(_own(e) for e in mine if not e.status) else []),
    ]
    sources = dict.fromkeys(e.source for e in mine if e.source)
    return text + ["Sources: " + "; ".join(_source(s, r) for s in sources) + ".", ""]


FOOTNOTES = (
    ("one run: ", "‡ The shipped model's one run ({where}): the five-seed data file holds no "
     "per-task seconds or oracle calls (its optimal share may differ from the five seeds' mean; "
     "the one run is today's code, the seeds report says when the five seeds were scored)."),
    ("modules: ", "† Mean modules of the shipped model's one run ({where}): the five-seed data "
     "file predates its modules column."),
)  # fmt: skip
"""(the prefix of an entry's note that names a file, the footnote it gives) of a tier's rows
that take a column from the shipped model's one run."""


def tier_footnotes(mine: list[Entry], r: str) -> list[str]:
    """The ‡ and † notes of a tier whose learned rows take a column from the shipped model's
    one run (the five-seed data files lack it)."""
    text = []
    for prefix, note in FOOTNOTES:
        paths = sorted({n.removeprefix(prefix) for e in mine for n in e.notes
                        if n.startswith(prefix)})  # fmt: skip
        if paths:
            where = "; ".join(f"`{r}{p.removeprefix('results/')}`" for p in paths)
            text += [note.format(where=where), ""]
    return text


def _models(tier, mine: list[Entry]) -> str:
    """Where the tier's learned methods come from, in a sentence (or nothing), with the
    number of training runs their rows average (read from the rows, so the two agree)."""
    counts = sorted({e.seeds for e in mine if e.kind == "learned" and not e.status})
    words = " or ".join(COUNTS[n] if n < len(COUNTS) else str(n) for n in counts)
    runs = "one training run" if counts == [1] else f"{words} training seeds"
    if tier.fault and counts:
        return f" The learned methods are trained with the failure (the tier's recipe, {runs})."
    if tier.model_tier and counts:
        return (f" The learned methods are the `{tier.model_tier}` tier's models (its recipe's "
                f"{runs}), acting here zero-shot.")  # fmt: skip
    return ""


COUNTS = ("no", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten")


def _source(source: str, prefix: str) -> str:
    if not source.startswith("results/"):  # written by this run (--out)
        return f"`{source}`"
    command = made_by(ROOT / source)
    if source.endswith(RESCORED):
        command = f"{COMMAND} --rescore-searches --force"
    shown = f"`{prefix}{source.removeprefix('results/')}`"
    return shown + (f" (`{command}`)" if command else "")


def made_by(path: Path) -> str:
    """The command a committed report names in its first lines ("Made by `...`")."""
    md = path.with_suffix(".md")
    if not md.is_file():
        return ""
    for line in md.read_text().splitlines()[:6]:
        if "Made by `" in line:
            return line.split("Made by `", 1)[1].split("`", 1)[0]
    return ""


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("leaderboard_page"))
