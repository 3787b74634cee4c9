"""Figure titles that stay on the figure: a task's name cut to one short line, the explanation
wrapped."""

from __future__ import annotations

MAX_TITLE_NAME = 48
"""Most characters of a task's name in a figure's title (longer names are cut with "...")."""

TITLE_WIDTH = 110
"""Characters per line of a figure's title (wrapped beyond)."""


def short_name(name: str | None, limit: int = MAX_TITLE_NAME) -> str:
    """A task's name for a title: one line, cut to ``limit`` characters with "..."."""
    name = " ".join(str(name).split()) if name else ""
    return name if len(name) <= limit else name[: limit - 3] + "..."


def figure_title(name: str | None, width: int = TITLE_WIDTH) -> str:
    """The title of a structure figure with a task: the task's name, cut to
    :data:`MAX_TITLE_NAME` characters, and what the points mean, wrapped to ``width``
    characters a line (default :data:`TITLE_WIDTH`; a long name never runs off the figure)."""
    import textwrap

    name = short_name(name)
    text = (f"task {name}: " if name else "") + (
        "points are the task's wrenches, green where the structure can exert the whole 6-D "
        "wrench, red where not"
    )
    return textwrap.fill(text, width, break_long_words=True)
