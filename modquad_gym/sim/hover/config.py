"""Hover settings: the controller's tuning (:class:`HoverGains`) and the run (:class:`HoverConfig`).

Every field is checked when the dataclass is made, so a bad value fails before any simulation,
with a one-line ``ValueError`` naming the field.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from modquad_gym.core.validation import check_f_max, check_real

LOAD_FRAMES = ("world", "body")
"""How the external load moves when the structure tilts (:mod:`.load`)."""

LOAD_RAMP_PROFILES = ("cosine", "linear")
"""How an unknown load goes from one task wrench to the next (:mod:`.load`)."""


@dataclass(frozen=True)
class HoverGains:
    """Controller tuning (:mod:`.gains`): natural frequencies in rad/s.

    Attributes:
        omega_pos: position loop (LQR weight ``omega_pos^4``; PD fallback ``Kp = omega_pos^2``).
        omega_att: attitude loop, likewise.
        damping: damping ratio of both loops (rate weights ``(4 damping^2 - 2) omega^2``).
        omega_int: integral action with an unknown load (LQI weights ``omega_int^2 omega^4``).
        unreachable_weight: extra weight on the position along M n, n an unreachable wrench
            direction, so that a line's tilt-to-translate loop is not slow.
        omega_obs: bandwidth of the load observer with an unknown load (:mod:`.estimator`),
            rad/s; 0 turns it off (integral action alone finds the load).
    """

    omega_pos: float = 4.0
    omega_att: float = 8.0
    damping: float = 1.0
    omega_int: float = 4.0
    unreachable_weight: float = 100.0
    omega_obs: float = 40.0

    def __post_init__(self) -> None:
        for name in ("omega_pos", "omega_att", "damping"):
            check_real(getattr(self, name), name, positive=True)
        for name in ("omega_int", "unreachable_weight", "omega_obs"):
            check_real(getattr(self, name), name, low=0.0)


@dataclass(frozen=True)
class HoverConfig:
    """How a hover is flown (:func:`modquad_gym.sim.hover.run_hover`); defaults are the package's.

    Attributes:
        f_max: rotor thrust limit (ignored when ``run_hover`` is given a model).
        seconds_per_wrench: simulated seconds per task segment.
        control_hz: controller rate; must divide the physics rate (1 / timestep).
        gains: controller tuning.
        takeoff_seconds: length of the take-off segment (0 skips it and the perturbation).
        initial_offset: start position minus the reference, metres (world frame).
        initial_tilt_rad: start tilt about the axis (1, 1, 0) / sqrt(2).
        settle_fraction: the last fraction of each segment over which errors are measured.
        drift_limit_m: position error that ends a segment as diverged.
        drift_limit_rad: attitude error that ends a segment as diverged.
        recover_limit_m: a segment that runs its course but ends with a position error above
            this is marked diverged too (it did not recover).
        known_load: the controller is told each task wrench (feed-forward); False: a load
            observer plus integral action estimate it (:mod:`.estimator`).
        load_frame: ``"world"`` or ``"body"``, see :data:`LOAD_FRAMES`.
        load_ramp_seconds: unknown load only: the load goes from the previous task wrench to the
            next over this many seconds at the start of each segment (0: a step). It must end
            before the settled part: at most ``(1 - settle_fraction) * seconds_per_wrench``.
            Ignored with a known load (a step).
        load_ramp_profile: ``"cosine"`` or ``"linear"``, see :data:`LOAD_RAMP_PROFILES`.
    """

    f_max: float = 1.0
    seconds_per_wrench: float = 2.0
    control_hz: float = 500.0
    gains: HoverGains = field(default_factory=HoverGains)
    takeoff_seconds: float = 2.0
    initial_offset: tuple[float, float, float] = (0.03, -0.02, 0.02)
    initial_tilt_rad: float = 0.05
    settle_fraction: float = 0.3
    drift_limit_m: float = 1.0
    drift_limit_rad: float = 1.0
    recover_limit_m: float = 0.1
    known_load: bool = True
    load_frame: str = "world"
    load_ramp_seconds: float = 1.0
    load_ramp_profile: str = "cosine"

    def __post_init__(self) -> None:
        check_f_max(self.f_max)
        for name in ("seconds_per_wrench", "control_hz", "recover_limit_m"):
            check_real(getattr(self, name), name, positive=True)
        for name in ("drift_limit_m", "drift_limit_rad"):
            check_real(getattr(self, name), name, positive=True)
        check_real(self.settle_fraction, "settle_fraction", high=1.0, positive=True)
        check_real(self.takeoff_seconds, "takeoff_seconds", low=0.0)
        check_real(self.initial_tilt_rad, "initial_tilt_rad")
        if len(self.initial_offset) != 3:
            raise ValueError(f"initial_offset must have 3 entries, got {self.initial_offset!r}")
        for x in self.initial_offset:
            check_real(x, "initial_offset")
        if not isinstance(self.gains, HoverGains):
            raise ValueError(f"gains must be a HoverGains, got {type(self.gains).__name__}")
        if not isinstance(self.known_load, bool):
            raise ValueError(f"known_load must be True or False, got {self.known_load!r}")
        if self.load_frame not in LOAD_FRAMES:
            raise ValueError(f"load_frame must be one of {LOAD_FRAMES}, got {self.load_frame!r}")
        if self.load_ramp_profile not in LOAD_RAMP_PROFILES:
            raise ValueError(
                f"load_ramp_profile must be one of {LOAD_RAMP_PROFILES}, "
                f"got {self.load_ramp_profile!r}"
            )
        check_real(self.load_ramp_seconds, "load_ramp_seconds", low=0.0)
        room = (1.0 - self.settle_fraction) * self.seconds_per_wrench
        if self.ramp_seconds > room + 1e-9:
            raise ValueError(
                f"load_ramp_seconds {self.ramp_seconds:g} reaches into the settled part of the "
                f"segment: need <= (1 - settle_fraction) * seconds_per_wrench = {room:g}"
            )

    @property
    def ramp_seconds(self) -> float:
        """The ramp actually flown: ``load_ramp_seconds`` with an unknown load, else 0 (a step)."""
        return 0.0 if self.known_load else float(self.load_ramp_seconds)

    @classmethod
    def make(cls, config: HoverConfig | None = None, **changes: object) -> HoverConfig:
        """``config`` (default: the defaults) with the named fields replaced (validated).

        ``gains=None`` stands for the default gains, as the keyword API always allowed."""
        if config is not None and not isinstance(config, HoverConfig):
            raise ValueError(f"config must be a HoverConfig, got {type(config).__name__}")
        if changes.get("gains", True) is None:
            changes["gains"] = HoverGains()
        unknown = sorted(set(changes) - {f.name for f in dataclasses.fields(cls)})
        if unknown:
            raise ValueError(f"unknown hover option(s) {', '.join(unknown)}")
        return dataclasses.replace(config or cls(), **changes)

    def control_steps(self, timestep: float) -> tuple[int, float]:
        """(physics steps per control step, control period in s) for a physics ``timestep``."""
        substeps = round(1.0 / (self.control_hz * timestep))
        if substeps < 1 or abs(substeps * self.control_hz * timestep - 1.0) > 1e-9:
            raise ValueError(
                f"control_hz {self.control_hz} must divide the physics rate {1 / timestep:g} Hz"
            )
        return substeps, 1.0 / self.control_hz

    def segment_steps(self) -> tuple[int, int, int]:
        """(control steps per task segment, in the take-off, in a settled window)."""
        n_ctrl = max(1, round(self.seconds_per_wrench * self.control_hz))
        n_takeoff = round(self.takeoff_seconds * self.control_hz)
        return n_ctrl, n_takeoff, max(1, round(self.settle_fraction * n_ctrl))
