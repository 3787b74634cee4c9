"""Example task files shipped with the package (``modquad_gym/data/examples``).

They travel with the wheel, so the documentation's commands work after ``pip install``: a task
argument ``example:NAME`` (e.g. ``modquad solve --task example:screwdriver``) reads the shipped
file, and ``modquad task example NAME --out FILE`` copies it out. The repository's ``examples/``
folder links to the same files; ``examples/make_examples.py`` regenerates them.
"""

from __future__ import annotations

from pathlib import Path

EXAMPLES_DIR = Path(__file__).resolve().parent.parent / "data" / "examples"
"""Where the example task files live inside the installed package."""

PREFIX = "example:"
"""A task argument that starts with this names a shipped example (``example:screwdriver``)."""


def example_names() -> list[str]:
    """The shipped examples by name: the file name, without ``.json`` for JSON files."""
    files = sorted(p.name for p in EXAMPLES_DIR.iterdir() if p.is_file())
    return [name.removesuffix(".json") for name in files]


def example_path(name: str) -> Path:
    """The file of the shipped example ``name`` (``screwdriver``, ``paper_seed0.csv``, ...);
    a ValueError lists the known names."""
    name = str(name).removeprefix(PREFIX)
    for candidate in (name, f"{name}.json"):
        path = EXAMPLES_DIR / candidate
        if "/" not in candidate and "\\" not in candidate and path.is_file():
            return path
    raise ValueError(f"unknown example {name!r}; known: {', '.join(example_names())}")


def resolve_task_path(spec) -> Path:
    """``spec`` as a path: ``example:NAME`` becomes the shipped file, anything else is kept."""
    text = str(spec)
    return example_path(text) if text.startswith(PREFIX) else Path(spec)
