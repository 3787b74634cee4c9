"""Benchmarks: scripts that measure speed and write reports to ``results/``.

Every report states the machine it ran on and compares methods as ratios within one run.
"""

from __future__ import annotations

import os
import platform
from pathlib import Path

from ..outputs import write_csv, write_text

__all__ = ["machine_description", "markdown_table", "write_csv", "write_text"]


def machine_description() -> str:
    """One line naming the CPU, its core count and the absence of a GPU."""
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
    """A GitHub markdown table of dict rows."""
    keys = list(rows[0])

    def fmt(v):
        return format(v, floatfmt) if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines)
