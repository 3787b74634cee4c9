"""The numbers of results quoted in the docs, filled from the reports (an MkDocs hook and a script).

A page quotes a result as ``<!--n KEY-->TEXT<!--/n-->``; TEXT is generated from the committed
report named by KEY, with its statistic beside the number, so that a result reads the same on
every page and as in the leaderboard:

* ``seeds TIER METHOD METRIC``: a learned method over the training seeds of
  ``results/seeds_TIER/seeds.csv``, as the leaderboard counts it: per seed the metric pooled over
  the tier's held-out tasks, then the mean over seeds with its 95 % percentile bootstrap interval
  (seeds resampled; ``benchmarks.leaderboard_entries.over_seeds``);
* ``run FOLDER METHOD METRIC``: one run of ``results/FOLDER/benchmark.csv`` (a deterministic
  search, or the shipped model), over the tier's held-out tasks;
* ``pair FOLDER METHOD RIVAL``: the same run task by task, over the tasks both solve: on how
  many METHOD answers with fewer modules than RIVAL and on how many with more, the mean
  difference with its 95 % percentile bootstrap interval (tasks resampled, 10,000 resamples,
  seed 0), and METHOD's mean seconds as a share of RIVAL's;
* ``scale FOLDER BAND solves|modules``: the learned designer's seeds at one size band of
  ``results/FOLDER/report.csv`` (``python -m benchmarks.scale_seeds``): the share of the tasks
  greedy solves that ``ppo`` solves, or its modules above greedy's, mean of the seeds [95 % CI].

METRIC is ``optimal`` (share solved with the certified optimum), ``success`` or ``evaluated``
(configurations per task); of a run also ``modules`` (mean modules over the tasks it solved),
``seconds`` or ``oracle_calls`` (per task), as the run's ``benchmark.md`` prints them, so that
a table row quoting several columns of one run reads them all from it. The build fills the
markers (``on_page_markdown``); ``python docs/result_numbers.py`` rewrites the pages in place
(README.md and docs/*.md), and tests/test_docs_pages.py checks that the committed pages hold
what it would write.
"""

from __future__ import annotations

import re
import sys
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
MARKER = re.compile(r"<!--n (?P<key>[^>]+?)-->(?P<text>.*?)<!--/n-->", re.S)
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


@cache
def _tier(folder: str) -> tuple[str, int]:
    """(tier name, n_max) of a report folder, from its ``benchmark.md`` or ``seeds.md``."""
    from modquad_gym.scoring.tiers import get_tier

    for name in ("benchmark.md", "seeds.md"):
        path = RESULTS / folder / name
        if path.is_file():
            found = re.search(r"tier `([^`]+)`", path.read_text())
            if found:
                return found.group(1), get_tier(found.group(1)).n_max
    raise ValueError(f"results/{folder}: no report naming its tier")


RUN_COLUMNS = {"optimal": ("optimal_share", "{:.1%}"), "success": ("success_rate", "{:.1%}"),
               "evaluated": ("mean_evaluated", "{:.1f}"), "modules": ("mean_modules", "{:.2f}"),
               "seconds": ("mean_seconds", "{:.4f}"),
               "oracle_calls": ("mean_oracle_calls", "{:,.0f}")}  # fmt: skip
"""A run's metric -> (its column of ``scores.summarise``, its format)."""


def _format(metric: str, value: float) -> str:
    return RUN_COLUMNS[metric][1].format(value).replace("%", " %")


@cache
def _seeds_entries(tier: str, stamp: tuple[int, int]) -> dict:
    """The learned methods' leaderboard entries of ``results/seeds_TIER/seeds.csv`` by method,
    computed once per version of the file (``stamp``: its size and mtime): the pages quote
    each tier's file many times, and each computation bootstraps every metric's interval."""
    sys.path.insert(0, str(ROOT))
    from benchmarks.leaderboard_entries import over_seeds, read_seeds
    from modquad_gym.scoring.tiers import get_tier

    records = read_seeds(RESULTS / f"seeds_{tier}" / "seeds.csv")
    return {e.method: e for e in over_seeds(records, get_tier(tier), "", {})}


def seeds_number(tier: str, method: str, metric: str) -> str:
    """A learned method over seeds: the mean over seeds [95 % CI] and what it is."""
    found = (RESULTS / f"seeds_{tier}" / "seeds.csv").stat()
    entries = _seeds_entries(tier, (found.st_size, found.st_mtime_ns))
    if method not in entries:
        raise ValueError(f"seeds_{tier}: no method {method!r} (has {', '.join(entries)})")
    e = entries[method]
    point, low, high = getattr(e, metric)
    unit = " %" if metric in ("optimal", "success") else ""
    k = 100 if unit else 1
    return (
        f"{k * point:.1f}{unit} [{k * low:.1f}, {k * high:.1f}] (mean of {e.seeds} seeds, "
        f"{e.tasks} held-out tasks, 95 % CI)"
    )


def run_number(folder: str, method: str, metric: str) -> str:
    """One run of a benchmark report: the share or mean over the tier's held-out tasks."""
    sys.path.insert(0, str(ROOT))
    from benchmarks.leaderboard_entries import read_rows
    from modquad_gym.scoring.scores import summarise

    _, n_max = _tier(folder)
    rows = read_rows(RESULTS / folder / "benchmark.csv")
    (s,) = summarise(rows, [method], n_max) or [None]
    if s is None:
        raise ValueError(f"results/{folder}/benchmark.csv: no rows of {method!r}")
    value = s[RUN_COLUMNS[metric][0]]
    if value is None:
        raise ValueError(f"results/{folder}/benchmark.csv: {method!r} solved no task")
    return f"{_format(metric, value)} (one run, {s['tasks']} held-out tasks)"


def pair_number(folder: str, method: str, rival: str) -> str:
    """One run task by task: METHOD's modules against RIVAL's on the tasks both solve."""
    import numpy as np

    sys.path.insert(0, str(ROOT))
    from benchmarks.leaderboard_entries import in_scope, read_rows

    _, n_max = _tier(folder)
    rows = in_scope(read_rows(RESULTS / folder / "benchmark.csv"), n_max)
    by = {m: {r.task: r for r in rows if r.method == m} for m in (method, rival)}
    for m in (method, rival):
        if not by[m]:
            raise ValueError(f"results/{folder}/benchmark.csv: no rows of {m!r}")
    both = [t for t in by[method] if t in by[rival] and by[method][t].success
            and by[rival][t].success]  # fmt: skip
    if not both:
        raise ValueError(f"results/{folder}/benchmark.csv: no task both {method} and {rival} solve")
    diff = np.array([by[method][t].n_modules - by[rival][t].n_modules for t in both])
    boots = diff[np.random.default_rng(0).integers(0, len(diff), (10_000, len(diff)))].mean(1)
    low, high = np.percentile(boots, [2.5, 97.5])
    seconds = {m: np.mean([r.seconds for r in by[m].values()]) for m in (method, rival)}
    return (
        f"fewer modules than {rival} on {(diff < 0).sum()} tasks and more on {(diff > 0).sum()} "
        f"(one run, {len(both)} held-out tasks both solve: {diff.mean():+.2f} modules a task "
        f"[{low:+.2f}, {high:+.2f}], 95 % bootstrap over the tasks; "
        f"{seconds[method] / seconds[rival]:.2f} of {rival}'s seconds)"
    )


def scale_number(folder: str, band: str, metric: str) -> str:
    """The learned designer's seeds at one band, beside greedy (``benchmarks.scale_seeds``)."""
    import csv

    with open(RESULTS / folder / "report.csv", newline="") as fh:
        rows = {r["band"]: r for r in csv.DictReader(fh)}
    if band not in rows:
        raise ValueError(f"results/{folder}/report.csv: no band {band} (has {', '.join(rows)})")
    r = rows[band]
    value = r["ppo_solves_greedys_pct"] if metric == "solves" else r["ppo_minus_greedy_modules"]
    point, interval = value.split(" ", 1)
    unit = " %" if metric == "solves" else " modules"
    return (
        f"{point}{unit} {interval} (mean of {r['seeds']} seeds, {r['greedy_solved']} held-out "
        f"tasks that greedy solves, 95 % CI)"
    )


METRICS = {"seeds": ("optimal", "success", "evaluated"), "run": tuple(RUN_COLUMNS),
           "scale": ("solves", "modules")}  # fmt: skip


def number(key: str) -> str:
    """The text of one marker's KEY."""
    kind, *args = key.split()
    makers = {"seeds": seeds_number, "run": run_number, "scale": scale_number, "pair": pair_number}
    if kind not in makers or len(args) != 3 or (kind != "pair" and args[2] not in METRICS[kind]):
        raise ValueError(f"bad result marker {key!r}: 'seeds TIER METHOD optimal|success|"
                         f"evaluated', 'run FOLDER METHOD {'|'.join(RUN_COLUMNS)}', 'pair FOLDER "
                         "METHOD RIVAL' or 'scale FOLDER BAND solves|modules'")  # fmt: skip
    return makers[kind](*args)


def fill(text: str) -> str:
    """``text`` with every marker's TEXT generated from its report."""
    return MARKER.sub(lambda m: f"<!--n {m['key']}-->{number(m['key'])}<!--/n-->", text)


def on_page_markdown(markdown, page, config, files):
    return fill(markdown)


def main(argv: list[str] | None = None) -> int:
    """Rewrite the pages in place (no options: an unknown one is refused, exit 2)."""
    from modquad_gym.core.options import OneLineParser

    OneLineParser(
        prog="python docs/result_numbers.py",
        description="Fill the docs' quoted results (<!--n KEY-->...<!--/n-->) in README.md and "
        "docs/*.md from the committed reports under results/.",
    ).parse_args(argv)
    for page in PAGES:
        text = page.read_text()
        filled = fill(text)
        if filled != text:
            page.write_text(filled)
            print(f"filled {page.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
