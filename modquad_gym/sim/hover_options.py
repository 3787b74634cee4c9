"""The hover options of a validation and their one check, shared by :func:`.validate.validate`
and ``modquad validate`` (each door naming them its own way: ``hover_seconds`` or
``--hover-seconds``). Imports nothing heavy: the command line checks its options before MuJoCo
loads."""

from __future__ import annotations

from modquad_gym.core.validation import check_int, check_real

DEFAULT_HOVER_WRENCHES = 20
"""Task wrenches hovered under when not told: the half nearest the boundary and a seeded sample
of the rest (:func:`.validate.hover_wrench_sample`); each takes two flights of
``hover_seconds``, so every wrench of a long task would take minutes."""

DEFAULT_HOVER_SECONDS = 2.0
"""Simulated seconds per hover segment."""

MIN_HOVER_SECONDS = 0.05
MAX_HOVER_SECONDS = 60.0
"""The range of ``hover_seconds``: a segment long enough to settle (its last 30 % is measured),
and short enough that a run stays minutes per wrench."""

DEFAULT_LOAD_RAMP = 1.0
"""Seconds of the unknown-load ramp when none is given (shortened to the part of a short segment
before its settled part)."""

PYTHON_NAMES = {n: n for n in ("hover_seconds", "load_ramp_seconds", "max_hover_wrenches")}
"""The options as :func:`.validate.validate` names them."""
CLI_NAMES = {n: "--" + n.replace("_", "-") for n in PYTHON_NAMES}
"""The options as ``modquad validate`` names them."""


def checked_hover(
    hover_seconds: object,
    load_ramp_seconds: object = None,
    max_hover_wrenches: object = DEFAULT_HOVER_WRENCHES,
    names: dict[str, str] = PYTHON_NAMES,
) -> tuple[float, float, int | None]:
    """(seconds per hover segment, unknown-load ramp, most wrenches hovered under), checked:
    ``hover_seconds`` in [:data:`MIN_HOVER_SECONDS`, :data:`MAX_HOVER_SECONDS`],
    ``load_ramp_seconds`` in [0, hover_seconds] (None: :data:`DEFAULT_LOAD_RAMP`, which a short
    segment shortens), ``max_hover_wrenches`` an integer >= 1 (None: every wrench). A ValueError
    names the option as ``names`` spells it (:data:`PYTHON_NAMES`, :data:`CLI_NAMES`)."""
    seconds = check_real(
        hover_seconds, names["hover_seconds"], MIN_HOVER_SECONDS, MAX_HOVER_SECONDS
    )
    ramp = DEFAULT_LOAD_RAMP
    if load_ramp_seconds is not None:  # only a ramp the caller gave is held to their segments
        ramp = check_real(load_ramp_seconds, names["load_ramp_seconds"], low=0.0)
        if ramp > seconds:
            raise ValueError(
                f"{names['load_ramp_seconds']} must be <= {names['hover_seconds']} "
                f"({seconds:g}), got {ramp:g}"
            )
    most = max_hover_wrenches
    if most is not None:
        most = check_int(most, names["max_hover_wrenches"], low=1)
    return seconds, ramp, most
