"""What made a ``modquad score`` report, recorded in it: the seed (given or defaulted), the
versions of modquad_gym and of the packages that decided its numbers, each method's setup
seconds (made once, before its tasks) and the fresh-process re-verification of its successes."""

from __future__ import annotations

import subprocess
import sys
from importlib import metadata
from pathlib import Path

CORE = ("numpy", "scipy", "gymnasium", "daqp")
"""Packages every run uses (the oracle, the environments)."""
WHEN_IMPORTED = ("highspy", "torch", "stable_baselines3", "sb3_contrib", "ray")
"""Packages recorded when the run imported them (the MILP's solver, the learned methods, the
workers)."""


def _version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        module = sys.modules.get(name)
        return str(getattr(module, "__version__", "not installed"))


def commit() -> str | None:
    """The git commit of the modquad_gym checkout in use, ``-dirty`` with local changes (None
    for an installed wheel)."""
    root = Path(__file__).resolve().parents[2]
    if not (root / ".git").exists():
        return None
    try:
        done = subprocess.run(["git", "-C", str(root), "describe", "--always", "--dirty"],
                              capture_output=True, text=True, timeout=10)  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() or None


def package_versions() -> dict[str, str]:
    """modquad_gym's version (with its commit in a checkout), the :data:`CORE` packages' and
    those of :data:`WHEN_IMPORTED` that this process imported."""
    from modquad_gym import __version__

    sha = commit()
    out = {"modquad_gym": __version__ + (f" (commit {sha})" if sha else "")}
    out.update({name: _version(name) for name in CORE})
    out.update({name: _version(name) for name in WHEN_IMPORTED if name in sys.modules})
    return out


def versions_words() -> str:
    """:func:`package_versions` in one line: ``modquad_gym 0.1.0, numpy 1.26.4, ...``."""
    return ", ".join(f"{name} {v}" for name, v in package_versions().items())


def run_record(seed: int, given: bool, setup: dict[str, float], methods: list[str],
               checked: tuple[int, float]) -> list[str]:  # fmt: skip
    """The report's section on what made it: the seed, the versions, each method's setup
    seconds (``setup``: by method, those made in this process) and the re-verification
    (``checked``: success rows verified again in a fresh process, its seconds)."""
    said = "given by `--seed`" if given else "the default: `--seed` not given"
    rows, seconds = checked
    lines = [
        "## Run record",
        "",
        f"- Seed: {seed} ({said}); told to the methods that draw at random.",
        f"- Versions: {versions_words()}.",
        f"- Re-verified in a fresh process (it imports modquad_gym, never an outside agent's "
        f"module): {rows} success rows, every method's, each on its task read again from its "
        f"suite file or drawn again from its validation seed, in {seconds:.1f} s. Seconds, "
        "configurations and oracle calls are measured in the scoring process, where outside "
        "agents run (honour-based).",
        "",
        "Setup seconds: each method is made once before its tasks (an outside agent's import "
        'and constructor, a learned method\'s model); not counted in seconds / task. "-": made '
        "in each worker (`--workers`), not measured here.",
        "",
        "| method | setup seconds |",
        "|---|---|",
        *(f"| {m} | {setup[m]:.3f} |" if m in setup else f"| {m} | - |" for m in methods),
        "",
    ]
    return lines
