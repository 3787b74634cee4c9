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
* ``scale FOLDER BAND solves|modules``: the learned designer's seeds at one size band of
  ``results/FOLDER/report.csv`` (``python -m benchmarks.scale_seeds``): the share of the tasks
  greedy solves that ``ppo`` solves, or its modules above greedy's, mean of the seeds [95 % CI].

METRIC is ``optimal`` (share solved with the certified optimum), ``success`` or ``evaluated``
(configurations per task). The build fills the markers (``on_page_markdown``);
``python docs/result_numbers.py`` rewrites the pages in place (README.md and docs/*.md), and
tests/test_docs_pages.py checks that the committed pages hold what it would write.
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


def _format(metric: str, value: float) -> str:
    return f"{100 * value:.1f} %" if metric in ("optimal", "success") else f"{value:.1f}"


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
    key = {"optimal": "optimal_share", "success": "success_rate", "evaluated": "mean_evaluated"}
    return f"{_format(metric, s[key[metric]])} (one run, {s['tasks']} held-out tasks)"


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


METRICS = {"seeds": ("optimal", "success", "evaluated"), "run": ("optimal", "success", "evaluated"),
           "scale": ("solves", "modules")}  # fmt: skip


def number(key: str) -> str:
    """The text of one marker's KEY."""
    kind, *args = key.split()
    makers = {"seeds": seeds_number, "run": run_number, "scale": scale_number}
    if kind not in makers or len(args) != 3 or args[2] not in METRICS[kind]:
        raise ValueError(f"bad result marker {key!r}: 'seeds|run WHERE METHOD optimal|success|"
                         "evaluated' or 'scale FOLDER BAND solves|modules'")  # fmt: skip
    return makers[kind](*args)


def fill(text: str) -> str:
    """``text`` with every marker's TEXT generated from its report."""
    return MARKER.sub(lambda m: f"<!--n {m['key']}-->{number(m['key'])}<!--/n-->", text)


def on_page_markdown(markdown, page, config, files):
    return fill(markdown)


def main(argv: list[str] | None = None) -> int:
    """Rewrite the pages in place (no options: an unknown one is refused, exit 2)."""
    import argparse

    argparse.ArgumentParser(
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
