"""Scoring agents on the benchmark tiers: the tiers and their held-out suites (:mod:`.tiers`,
:mod:`.suites`), one run of every method against the certified optimum (:mod:`.agents`,
``modquad score``), its report and figures, the five-seed scoring of trained agents
(:mod:`.seeds`) and the certified optima datasets (:mod:`.optima`, ``modquad optima``).

Every report states the machine it ran on (:func:`machine_description`) and compares methods
within one run. The project's other measurement scripts live outside the package, in the
repository's ``benchmarks/``.
"""

from __future__ import annotations

import os
import platform
from pathlib import Path

__all__ = ["machine_description", "markdown_table"]


def machine_description() -> str:
    """One line naming the CPU, its core count and the absence of a GPU: the machine line of
    every report (the benchmarks' too)."""
    model = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, no GPU, Python {platform.python_version()}"


def markdown_table(rows: list[dict], floatfmt: str = ".3g") -> str:
    """A GitHub markdown table of dict rows (the keys of the first row are the columns)."""
    keys = list(rows[0])

    def fmt(v):
        return format(v, floatfmt) if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines)
