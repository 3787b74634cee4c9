"""Free flight: the structure hovers under gravity and holds its pose against each task's load.

Setup (gravity on, no wall): a take-off segment first (not part of the task metrics): the structure
starts a few centimetres off (0, 0, HOME_HEIGHT) and tilted, and converges while hovering at half
thrust (the centre of its feasible set). Then the task wrenches are applied in turn,
``seconds_per_wrench`` each, with no reset in between (except after a diverged segment, below).

External load
-------------
A task wrench w is the *total* wrench the rotors must produce (gravity compensation folded into
f_z, normalised units). During segment i an external wrench ``d`` is applied at the COM through
``xfrc_applied`` such that at equilibrium (level, at the reference) the rotors produce exactly w:

    d = -(w + gravity wrench),   gravity wrench = [m g ; 0]  (world frame, torque-free at the COM).

So gravity plus load is ``-w``, and hovering in place needs A u = w. This keeps the physical weight
of the modules (``module_mass``) and the normalised task units independent.

With the load known to the controller, w switches at the start of each segment (a step; the
feed-forward switches with it). With the load unknown, a step of a multi-newton wrench is not
what a task looks like (a tool is pressed, a payload is taken up, over a moment), so the load
*ramps* from the previous segment's wrench w_prev to w over the first ``load_ramp_seconds`` of
the segment (default 1 s; 0 keeps the step): ``w(t) = w_prev + s(t / T) (w - w_prev)`` with
``s(x) = (1 - cos(pi x)) / 2`` (``load_ramp_profile="cosine"``, no jump in the load's rate at
either end) or ``s(x) = x`` (``"linear"``). The first task segment ramps from the take-off trim.
The feasible set is convex, so a ramp between two feasible wrenches stays feasible. The
controller is told neither the ramp nor its timing; the settled errors are measured over the
last ``settle_fraction`` of the segment, which must begin after the ramp ends
(``load_ramp_seconds <= (1 - settle_fraction) seconds_per_wrench``).

``load_frame`` says how the load moves when the structure tilts:

* ``"world"`` (default): ``-w`` is fixed in the world frame for the whole segment, like gravity,
  which the task's f_z stands for, or a tool pressed against a fixed surface. When the structure
  tilts by a small rotation theta, its rotor wrench turns with it and the load does not, so the
  net wrench gains ``-[[w_f]x ; [w_tau]x] theta``: tilting steers the force, as a quadrotor tilts
  to translate.
* ``"body"``: ``-w`` is fixed in {S} (recomputed with the current attitude at every control step),
  so the net wrench on the body is ``A u - w`` in {S} whatever the attitude.

Rank-deficient structures and the unreachable wrench direction
--------------------------------------------------------------
Every producible wrench A u lies in range(A). For a straight line of modules (rank 5) the missing
direction n (``A^T n = 0``, :func:`unreachable_wrench_directions`) is, for a line along x
(cells (i, 0)) with the default T-module, ``n = (0, 0.1497, 0, 0.9887, 0, 0)``:
``0.1497 f_y + 0.9887 tau_x = 0`` for every u. Read as a screw (:func:`wrench_axis`), no rotor
wrench has a moment about the axis parallel to the line through the point 0.151 m *above* the
COM: each rotor's thrust line and drag torque pass that axis with zero moment, for any line
length. A line along y misses the same combination of f_x and tau_y. In acceleration terms the
body cannot get ``n^T M [a ; alpha] != 0`` (M = diag(m I, J)): it can roll about the line's axis
only together with a sideways push, and a sideways push comes with a roll.

* Under a body-following load (``load_frame="body"``) the net wrench stays in range(A) in {S} at
  every attitude, so ``n^T M nu`` (nu the body twist) changes only through second-order
  (gyroscopic, omega x v) terms: the linearised hover has an *uncontrollable* double integrator,
  a mix of sideways position and roll about the line. No linear feedback can damp it: any
  momentum it picks up (the take-off transient injects some) makes it drift for ever, and the
  PD's equilibrium along it trades about 1 mm of sideways offset for 0.1 rad of roll, because the
  line's roll inertia is small. This is the audited creep (a 4-module line: 0.07 rad after the
  first task segment, 0.55 rad after six, 0.9 rad later; the 3-module screwdriver line settles at
  0.14 rad). It is a property of that load model, not of the structure: avoiding it needs a
  non-linear manoeuvre (yaw, slide along the line, yaw back) that the hover does not attempt. The
  body-following load is kept as an option to show this; such segments run the fallback PD.
* Under the world-fixed load (default) the tilt coupling above feeds the missing direction: its
  acceleration becomes ``n^T G theta = -theta . (n_f x w_f + n_tau x w_tau)``, which for a line
  along x contains ``0.1497 w_z theta_x``: the line rolls to push itself sideways, exactly like a
  quadrotor. The linearisation is then controllable whenever the task's f_z (the hover thrust) is
  not zero, and the LQR below holds position *and* attitude. Measured (2 s per wrench, load
  known): the screwdriver line settles at 8e-4 rad in its first task segment (the take-off's
  residual, still decaying) and 1e-4 rad in the second, instead of 0.14 rad; the 4-module line
  of ``examples/planted_seed1.json`` at 6e-4 rad in the first and below 1e-6 rad from the fourth
  on, instead of creeping to 0.55 rad. No attitude error about the unreachable axis is left at
  rest; none is physically unavoidable under this load. What remains is the transient: roll
  about the line can only be made together with a sideways force (about 6.6 N of f_y per N m of
  tau_x), so a line's roll authority is small and is the first thing lost when the rotors
  saturate (see the unknown load below).

A single module (rank 4) misses two directions; the world-fixed load makes it stabilisable in the
same way. Where the linearisation cannot be stabilised (body-following load on a line or a single
module, no hover thrust) the controller falls back to the projected PD and the segment may drift
(reported: ``controller`` in the segment metrics). A wrench off range(A) (oracle gamma = inf)
cannot be held by anything.

Controller (``control_hz``, default 500 Hz; the physics steps at 1 kHz)
------------------------------------------------------------------------
State ``x = [p - p_ref, theta, v, omega]``: position error and velocity in the world frame, theta
the rotation vector (log map) of R (reference level, R_ref = I), omega the body rates. The
linearisation about level hover with A u = w (:func:`hover_linearization`, checked against
MuJoCo's finite differences in the tests) is

    d/dt [p; theta] = [v; omega],   M d/dt [v; omega] = A du + G theta,
    G = -[[w_f]x ; [w_tau]x]  (world-fixed load),   G = 0  (body-following load).

* Gains: an LQR on this model, designed per segment, whose cost mimics critically damped PD loops
  on acceleration: state weights ``omega_pos^4`` (position), ``omega_att^4`` (attitude),
  ``2 omega^2`` (rates), input cost ``|M^-1 A du|^2`` (plus a tiny ``|du|^2`` for uniqueness). For
  a full-rank structure this *is* the PD with natural frequencies ``omega_pos`` and ``omega_att``
  (up to the small tilt coupling); for a line the LQR also uses the tilt coupling, and the
  position along the unreachable direction ``M n`` is weighted ``unreachable_weight`` times more
  so that this tilt-to-translate loop is not much slower than the others (slowest pole about
  -2.6 rad/s instead of -0.65). If the Riccati equation has no stabilising solution (body load on
  a line, a single module, a line with no hover thrust), the segment runs the fallback:
  ``w_des = w + P [R^T m (Kp e_p - Kd v) ; J (-Kr e_R - Kw omega)]`` with P = A A^+ the
  projection onto range(A), so the allocation never fights the unreachable direction.
* Desired wrench: ``w_des = w_ff + A du + P [0 ; omega x J omega]`` with ``du = -K x``.
* Load known (``known_load=True``, the default): the feed-forward is the task wrench itself,
  ``w_ff = w``, and the LQR is designed at w. A feasible wrench is then held with no transient at
  its switch-on, and the settled errors (what is left of the take-off transient, then ~1e-12 m)
  only show that the model is consistent; they are not a test of the controller.
* Load unknown (``known_load=False``): the controller is not told the task wrenches nor when they
  change (nor the ramps). ``w_ff = w_obs + w_hat``, an estimate of the load in two parts:

  - ``w_obs``, a load observer (a first-order disturbance observer of bandwidth ``omega_obs``,
    default 40 rad/s): over each control step, the wrench the rotors would have needed for no
    acceleration, ``A u - [m R^T dv/dt ; J d(omega)/dt + omega x J omega]`` (the rotor inputs
    sent, the measured velocities; projected onto range(A)), low-pass filtered. At rest it is
    A u, i.e. the load; it lags a changing load by about (rate of change) / ``omega_obs``. It
    uses the same model (m, J, A) as the LQR; in this simulation that model is exact, so the
    observer is exact up to its lag; on hardware, sensor noise would bound ``omega_obs``.
  - ``w_hat``, integral action for what the observer misses (model error, here its lag): an LQI
    whose states include the integrals of the position error and of the attitude error, in the
    directions where a level equilibrium can be held, with weights ``omega_int^2 omega^4``,
    written in velocity form ``d/dt w_hat = -A K_i C (e_p, theta)`` so that rescheduling the
    gains is bumpless. For a rank-5 line the integrated attitude directions are the two
    orthogonal to ``g = G^T n``: at rest ``g . theta = 0`` anyway, so these two pin theta = 0.
    Anti-windup: it integrates only while the allocation is exact (rotors not saturated).

  The estimate starts at the take-off trim (half thrust, the one thing the controller knows: its
  own trim); the gains are rescheduled on it (at most every 0.25 s, when it moved by over 5 %).
  ``omega_obs = 0`` removes the observer: integral action alone then finds the load (it
  integrates while the estimate stays allocatable), as in the first version of this hover.
  Why the observer: integral action can move the estimate only after a position error has built
  up, so it lags a 1 s ramp by most of the ramp; the feedback then carries the load, and near the
  boundary of the feasible set the allocation saturates, gives the (wrong) feed-forward priority
  over the correction and the structure drifts away (the integral winds up while saturated).
  Measured, ``examples/paper_seed0.json`` with its 5-module exhaustive structure, first 20
  wrenches, 2 s segments, integral action alone: a step load leaves 17 of 20 segments within
  1 cm (3 diverged, gamma 0.72-0.86); a 1 s ramp, 3 of 20 (the estimate has not caught up when
  the settled window starts; 3 s segments give 18 of 20). With the observer: all 20 within
  1 cm (0.2-2 mm with the ramp), none saturated once settled, none diverged, ramp or step.
  Braking after a change of load needs a wrench beyond w along the change, and
  :func:`step_headroom` measures how much the feasible set allows there. A step gives the
  observer no time: near the boundary the transient still saturates; a straight line then
  loses its roll (see above). On planted_seed1's 4-module line, first 20 wrenches: with the
  1 s ramp all 20 settle within 1 cm (errors 0.5-3 mm) and none diverges; the two wrenches at
  gamma 0.998 (headroom 0.013 and 0.007 N) stay saturated once settled, still within 2 mm,
  because an estimate 2 % off is already outside the feasible set there. With a step, 13 of
  20 settle within 1 cm and 4 diverge (gamma 0.68-0.998, headroom 0.007-1.5 N).
* Bounded allocation, u in [0, f_max]: ``u = u_ref + A^+ (w_des - A u_ref)`` around a reference
  u_ref, the oracle's most centred exact allocation (:func:`modquad_gym.oracle.allocate`) of the
  task wrench (known load, once per segment) or of the estimate (unknown load, when the gains
  are rescheduled). A^+ keeps every correction in range(A). When u leaves the box by more than
  1e-6 f_max, alternating projections between the box and {A u = w_des} look for an exact
  allocation strictly inside. If there is none, priorities apply: the feed-forward first, then
  the attitude part of the correction, then the position part, each scaled down (its direction
  kept) until it fits; if even the feed-forward cannot be allocated (an infeasible load), the
  bounded least-squares allocation ``min |M^-1 (A u - w_des)| s.t. 0 <= u <= f_max`` (scipy
  ``lsq_linear``; the error measured as acceleration). Whatever the path, the rotors receive a u
  inside the box, and saturation is reported honestly: a control step counts as saturated when
  any rotor sits at 0 or f_max (within 1e-6 f_max).

Metrics per segment, over its settled part (the last ``settle_fraction`` of it): maximum position
error (m), maximum attitude error (rad, the rotation angle of R), the saturated fraction (whole
segment and settled part) and, with an unknown load, the relative error of the load estimate at
the segment's end and the step headroom (along the change of load from the previous segment).
A segment whose position error exceeds ``drift_limit_m``, whose attitude error exceeds
``drift_limit_rad`` or whose state becomes non-finite ends early, is marked ``diverged`` with
the ``stop_reason`` and the time it stopped, and counts in full in the metrics. A segment that
runs its course but ends more than ``recover_limit_m`` (default 0.1 m) from the reference is
marked ``diverged`` too (``stop_reason`` "ended ... away"). After a diverged segment the state
is re-initialised before the next one, so that one divergence does not contaminate the next
segment's numbers: the structure restarts at home, level, at rest, at the hover equilibrium of
the diverged segment's load (the state a settled segment would have left; the take-off trim if
that load is infeasible). With an unknown load the estimate restarts at that load and the next
segment's load ramps (or steps) from it, as after any other segment. An infeasible wrench fails
this way: the rotors saturate, the net wrench cannot vanish, and the structure drifts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..oracle import TOL, allocate, check_f_max, check_wrenches, feasible
from ..structure import Structure
from .model import HOME_HEIGHT, SimModel, body_rotation, build_model

LOAD_FRAMES = ("world", "body")
"""How the external load moves when the structure tilts (module docstring)."""

LOAD_RAMP_PROFILES = ("cosine", "linear")
"""How an unknown load goes from one task wrench to the next (module docstring)."""

_RESCHEDULE_S = 0.25  # unknown load: shortest time between two gain designs
_RESCHEDULE_REL = 0.05  # unknown load: redesign when the estimate moved by this fraction
_AP_ITERATIONS = 60  # alternating projections tried before the linear programme
_AP_MARGIN = 1e-4  # ... into the box shrunk by this fraction of f_max (strictly inside)


@dataclass(frozen=True)
class HoverGains:
    """Controller tuning (module docstring): natural frequencies in rad/s.

    Attributes:
        omega_pos: position loop (LQR weight ``omega_pos^4``; PD fallback ``Kp = omega_pos^2``).
        omega_att: attitude loop, likewise.
        damping: damping ratio of both loops (rate weights ``(4 damping^2 - 2) omega^2``).
        omega_int: integral action with an unknown load (LQI weights ``omega_int^2 omega^4``).
        unreachable_weight: extra weight on the position along M n, n an unreachable wrench
            direction, so that a line's tilt-to-translate loop is not slow.
        omega_obs: bandwidth of the load observer with an unknown load (module docstring),
            rad/s; 0 turns it off (integral action alone finds the load).
    """

    omega_pos: float = 4.0
    omega_att: float = 8.0
    damping: float = 1.0
    omega_int: float = 4.0
    unreachable_weight: float = 100.0
    omega_obs: float = 40.0


@dataclass
class HoverResult:
    """Time series and per-segment metrics of a hover run.

    Attributes:
        wrenches: (t, 6) task wrenches, one segment each.
        f_max: rotor thrust limit.
        known_load: whether the controller was told the load (module docstring).
        load_frame: ``"world"`` or ``"body"``.
        time: (k,) control-step times in seconds.
        segment: (k,) the segment (wrench index, -1 for the take-off) of each control step.
        position_error: (k,) |p_ref - p| in metres.
        attitude_error: (k,) rotation angle of R away from level, radians.
        u: (k, 4n) rotor inputs sent.
        saturated: (k,) some rotor at 0 or f_max (within 1e-6 f_max).
        settled: (k,) the step lies in the settled part of a task segment.
        gamma: (t,) the oracle's gamma of each task wrench (<= 1 feasible, inf off range(A)).
        feasible: (t,) the oracle's verdict.
        diverged: (t,) the segment was cut short by drift (see the module docstring).
        load: (k, 6) the wrench the external load stood for at each control step (the task
            wrench, or its ramp from the previous one): d = -(load + gravity wrench).
        load_estimate: (k, 6) the controller's feed-forward: the load itself when known, the
            estimate w_obs + w_hat (observer + integral action) when not.
    """

    wrenches: np.ndarray
    f_max: float
    known_load: bool
    load_frame: str
    time: np.ndarray
    segment: np.ndarray
    position_error: np.ndarray
    attitude_error: np.ndarray
    u: np.ndarray
    saturated: np.ndarray
    settled: np.ndarray
    gamma: np.ndarray
    feasible: np.ndarray
    diverged: np.ndarray
    load: np.ndarray
    load_estimate: np.ndarray
    segment_metrics: list[dict] = field(default_factory=list)
    """Per segment (take-off first, index -1): gamma, controller, diverged (stop_reason,
    stop_time_s), settled errors, saturation, load estimate error (unknown load)."""
    load_ramp_seconds: float = 0.0
    """How long the load took to go from one task wrench to the next (0: a step)."""
    load_ramp_profile: str = "cosine"
    """``"cosine"`` or ``"linear"`` (meaningful when ``load_ramp_seconds > 0``)."""

    @property
    def max_position_error(self) -> float:
        """Largest settled position error over all segments, metres."""
        return float(self.position_error[self.settled].max(initial=0.0))

    @property
    def max_attitude_error(self) -> float:
        """Largest settled attitude error over all segments, radians."""
        return float(self.attitude_error[self.settled].max(initial=0.0))

    @property
    def saturated_fraction(self) -> float:
        """Fraction of the task's control steps (take-off excluded) with a rotor at 0 or f_max."""
        task = self.segment >= 0
        return float(self.saturated[task].mean()) if task.any() else 0.0

    @property
    def settled_saturated_fraction(self) -> float:
        """Fraction of the settled control steps with a rotor at 0 or f_max."""
        return float(self.saturated[self.settled].mean()) if self.settled.any() else 0.0

    @property
    def max_load_estimate_error(self) -> float | None:
        """Largest relative error |w_hat - w| / |w| of the load estimate at a segment's end
        (unknown load; None with a known load or no task segment)."""
        errs = [
            s["load_estimate_error"]
            for s in self.segment_metrics
            if s["segment"] >= 0 and s.get("load_estimate_error") is not None
        ]
        return max(errs) if errs else None


def _ramp_fraction(s: float, profile: str) -> float:
    """How far (0 to 1) a load ramp has gone at s in [0, 1] of its duration."""
    s = min(max(s, 0.0), 1.0)
    return 0.5 * (1.0 - math.cos(math.pi * s)) if profile == "cosine" else s


def _vee_skew(M: np.ndarray) -> np.ndarray:
    return 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])


def _skew(a: np.ndarray) -> np.ndarray:
    """[a]x, so that [a]x b = a x b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b for 3-vectors (np.cross is slow for one pair inside the control loop)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def rotation_angle(R: np.ndarray) -> float:
    """Angle (rad) of the rotation R, robust near 0 and pi."""
    s = np.linalg.norm(_vee_skew(R - R.T))
    c = 0.5 * (np.trace(R) - 1.0)
    return float(math.atan2(s, c))


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The rotation vector (axis times angle, the log map) of R; exact below pi."""
    s = _vee_skew(R - R.T)
    sn = float(np.linalg.norm(s))
    if sn < 1e-12:
        return s
    return s * (math.atan2(sn, 0.5 * (np.trace(R) - 1.0)) / sn)


def body_inertia(sim: SimModel) -> np.ndarray:
    """J (3, 3): the structure's inertia about its COM in {S}."""
    m = sim.model
    b = sim.body_id
    w, x, y, z = m.body_iquat[b]
    Q = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    return Q @ np.diag(m.body_inertia[b]) @ Q.T


def unreachable_wrench_directions(A: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    """(6, 6 - rank A): an orthonormal basis of the wrench directions A can never produce.

    Each column n satisfies ``n . (A u) = 0`` for every u (the left null space of A). Empty
    (6, 0) for a full-rank structure, one column for a straight line, two for one module. The
    sign of each column is fixed so that its largest entry is positive.
    """
    A = np.asarray(A, dtype=float)
    U, s, _ = np.linalg.svd(A)
    rank = int(np.sum(s > rtol * s[0])) if s.size and s[0] > 0 else 0
    N = U[:, rank:].copy()
    N[np.abs(N) < 1e-14] = 0.0
    for j in range(N.shape[1]):
        if N[np.argmax(np.abs(N[:, j])), j] < 0:
            N[:, j] *= -1.0
    return N


def wrench_axis(n: np.ndarray) -> dict:
    """Read an unreachable direction n = (n_f, n_tau) as a screw (an axis and a pitch).

    ``n . w = |n_tau| ((tau - r x f) . a + pitch f . a)`` for every wrench w = (f, tau), with the
    axis direction a = n_tau / |n_tau|, r = n_tau x n_f / |n_tau|^2 the axis point closest to the
    COM and pitch = n_f . n_tau / |n_tau|^2. So the rotors can never make a moment about that axis
    (plus pitch times force along it); with pitch 0 (straight lines), a pure moment about the axis.
    If n_tau = 0, n is a force direction the rotors cannot push along (axis None).
    """
    n = np.asarray(n, dtype=float)
    nf, nt = n[:3], n[3:]
    t2 = float(nt @ nt)

    def clean(x: np.ndarray) -> list[float]:  # round-off to exact zeros (readable reports)
        return [0.0 if abs(v) < 1e-12 else float(v) for v in x]

    if t2 < 1e-18:
        return {"axis": None, "point": None, "pitch": None, "force_direction": clean(nf)}
    pitch = float(nf @ nt / t2)
    return {
        "axis": clean(nt / math.sqrt(t2)),
        "point": clean(np.cross(nt, nf) / t2),
        "pitch": 0.0 if abs(pitch) < 1e-12 else pitch,
        "force_direction": None,
    }


def hover_linearization(
    A: np.ndarray, w: np.ndarray, mass: float, J: np.ndarray, load_frame: str = "world"
) -> tuple[np.ndarray, np.ndarray]:
    """Linearised hover about level, at the reference, with A u = w: ``dx/dt = F x + B du``.

    State x = [p - p_ref (world), theta (rotation vector), v (world), omega (body)] (12), input
    du = u - u_w (4n). ``M d/dt [v; omega] = A du + G theta`` with ``G = -[[w_f]x ; [w_tau]x]``
    for the world-fixed load (the rotor wrench tilts, the load does not) and G = 0 for the
    body-following load (module docstring).
    """
    if load_frame not in LOAD_FRAMES:
        raise ValueError(f"load_frame must be one of {LOAD_FRAMES}, got {load_frame!r}")
    Minv = np.zeros((6, 6))
    Minv[:3, :3] = np.eye(3) / mass
    Minv[3:, 3:] = np.linalg.inv(J)
    F = np.zeros((12, 12))
    F[:6, 6:] = np.eye(6)
    if load_frame == "world":
        G = -np.vstack([_skew(w[:3]), _skew(w[3:])])
        F[6:, 3:6] = Minv @ G
    B = np.zeros((12, A.shape[1]))
    B[6:] = Minv @ A
    return F, B


@dataclass
class _Design:
    """Gains of one segment: LQR (K, and K_i, C for the integral) or the PD fallback."""

    kind: str  # "lqr" or "pd_fallback"
    K: np.ndarray | None = None
    Ki: np.ndarray | None = None
    C: np.ndarray | None = None
    w: np.ndarray | None = None


def _design(
    A: np.ndarray,
    w: np.ndarray,
    mass: float,
    J: np.ndarray,
    gains: HoverGains,
    load_frame: str,
    integral: bool,
) -> _Design:
    """LQR (LQI with ``integral``) gains at w; the PD fallback if none stabilises (docstring)."""
    from scipy.linalg import solve_continuous_are

    F, B = hover_linearization(A, w, mass, J, load_frame)
    wp, wa, z = gains.omega_pos, gains.omega_att, gains.damping
    rate = max(4.0 * z * z - 2.0, 0.0)
    q = [wp**4, wa**4, rate * wp**2, rate * wa**2]  # position, attitude, velocity, rates
    Q = np.diag(np.repeat(q, 3))
    Mmat = np.zeros((6, 6))
    Mmat[:3, :3] = np.eye(3) * mass
    Mmat[3:, 3:] = J
    N = unreachable_wrench_directions(A)
    for j in range(N.shape[1]):
        d = Mmat @ N[:, j]
        d /= np.linalg.norm(d)
        Q[:6, :6] += gains.unreachable_weight * wp**4 * np.outer(d, d)
        Q[6:, 6:] += gains.unreachable_weight * rate * wp**2 * np.outer(d, d)
    MA = B[6:]
    Rm = MA.T @ MA
    Rm += 1e-6 * max(float(np.trace(Rm)) / Rm.shape[0], 1e-12) * np.eye(Rm.shape[0])
    C = None
    if integral:
        # integrate e_p and the attitude directions in which a level rest can be pinned
        if N.shape[1]:
            G = F[6:, 3:6] if load_frame == "world" else np.zeros((6, 3))
            NG = N.T @ (Mmat @ G)
            _, sv, vt = np.linalg.svd(NG)
            r = int(np.sum(sv > 1e-9 * max(1.0, float(np.abs(NG).max(initial=0.0)))))
            Bth = vt[r:].T
        else:
            Bth = np.eye(3)
        C = np.zeros((3 + Bth.shape[1], 6))
        C[:3, :3] = np.eye(3)
        C[3:, 3:] = Bth.T
        k = C.shape[0]
        Fa = np.zeros((12 + k, 12 + k))
        Fa[:12, :12] = F
        Fa[12:, :6] = C
        Ba = np.vstack([B, np.zeros((k, B.shape[1]))])
        qi = gains.omega_int**2 * np.concatenate([np.full(3, wp**4), np.full(k - 3, wa**4)])
        Qa = np.zeros((12 + k, 12 + k))
        Qa[:12, :12] = Q
        Qa[12:, 12:] = np.diag(qi)
        for j in range(N.shape[1]):  # the unreachable direction's integral, weighted likewise
            d = C @ (Mmat @ N[:, j])
            if np.linalg.norm(d) > 1e-12:
                d /= np.linalg.norm(d)
                qd = gains.unreachable_weight * gains.omega_int**2 * wp**4
                Qa[12:, 12:] += qd * np.outer(d, d)
        F, B, Q = Fa, Ba, Qa
    try:
        P = solve_continuous_are(F, B, Q, Rm)
        Kall = np.linalg.solve(Rm, B.T @ P)
        ok = bool(np.all(np.isfinite(Kall)))
        if ok:
            ok = float(np.linalg.eigvals(F - B @ Kall).real.max()) < -1e-2
    except (np.linalg.LinAlgError, ValueError):
        ok = False
    if not ok:
        return _Design("pd_fallback", w=w)
    return _Design("lqr", K=Kall[:, :12], Ki=Kall[:, 12:] if integral else None, C=C, w=w)


def step_headroom(
    A: np.ndarray, w: np.ndarray, w_prev: np.ndarray, f_max: float = 1.0
) -> float | None:
    """How far past w, along the load step w - w_prev, the rotors can still push (wrench units).

    The largest lambda >= 0 with w + lambda (w - w_prev) / |w - w_prev| feasible (a linear
    programme); None if w itself is infeasible, inf for no step. With an unknown load, the step
    pushes the structure away until the estimate catches up; braking back needs a wrench beyond w
    along the step, so a small headroom (a task wrench near the boundary of the feasible set in
    the direction it was approached from) means a large transient, however the controller is tuned.
    """
    from scipy.optimize import linprog

    d = np.asarray(w, dtype=float) - np.asarray(w_prev, dtype=float)
    nd = float(np.linalg.norm(d))
    if nd < 1e-12:
        return math.inf
    m = A.shape[1]
    cost = np.zeros(m + 1)
    cost[-1] = -1.0
    res = linprog(
        cost,
        A_eq=np.hstack([A, -(d / nd)[:, None]]),
        b_eq=w,
        bounds=[(0.0, f_max)] * m + [(0.0, None)],
        method="highs",
    )
    if res.status == 3:  # unbounded cannot happen with a bounded u; guard anyway
        return math.inf
    return float(res.x[-1]) if res.status == 0 else None


class _Allocator:
    """Bounded allocation around a centred exact reference allocation (module docstring)."""

    def __init__(self, A: np.ndarray, f_max: float, Minv: np.ndarray) -> None:
        self.A = A
        self.f_max = f_max
        self.pinv = np.linalg.pinv(A)
        self.tol = TOL * f_max
        self.u_ref = np.full(A.shape[1], f_max / 2.0)
        self.w_ref = A @ self.u_ref
        self.Minv = Minv
        self.MinvA = Minv @ A

    def recentre(self, w: np.ndarray) -> float:
        """Make the most centred exact allocation of w the reference (if w is feasible)."""
        u, gamma = allocate(self.A, w, self.f_max)
        if math.isfinite(gamma) and gamma <= 1.0 + TOL:
            self.u_ref, self.w_ref = u, self.A @ u
        return gamma

    def _in_box(self, u: np.ndarray) -> bool:
        return bool(np.all(u >= -self.tol) and np.all(u <= self.f_max + self.tol))

    def _interior(self, w: np.ndarray, u: np.ndarray) -> np.ndarray | None:
        """Alternating projections between the box (shrunk by _AP_MARGIN f_max) and the affine set
        {A u = w}: an exact allocation strictly inside the box, or None if none is found."""
        lo, hi = _AP_MARGIN * self.f_max, (1.0 - _AP_MARGIN) * self.f_max
        scale = 1e-9 * (1.0 + float(np.linalg.norm(w)))
        for _ in range(_AP_ITERATIONS):
            u = np.clip(u, lo, hi)
            r = w - self.A @ u
            if float(np.linalg.norm(r)) <= scale:
                return u
            u = u + self.pinv @ r
        return None

    def exact(self, w: np.ndarray) -> np.ndarray | None:
        """An allocation of w in the box (around the reference, else strictly inside), or None."""
        u = self.u_ref + self.pinv @ (w - self.w_ref)
        if self._in_box(u):
            return np.clip(u, 0.0, self.f_max)
        return self._interior(w, u)

    def _scaled(self, u0: np.ndarray, dw: np.ndarray) -> np.ndarray:
        """u0 + alpha A^+ dw with the largest alpha in [0, 1] that keeps it in the box."""
        du = self.pinv @ dw
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(du > 0, (self.f_max - u0) / du, np.where(du < 0, -u0 / du, np.inf))
        alpha = float(np.clip(room.min(initial=1.0), 0.0, 1.0))
        return np.clip(u0 + alpha * du, 0.0, self.f_max)

    def __call__(
        self, w_des: np.ndarray, w_ff: np.ndarray, w_att: np.ndarray
    ) -> tuple[np.ndarray, bool]:
        """(u in the box, whether A u = w_des was met).

        ``w_des = w_ff + w_att + w_pos``: feed-forward, attitude correction, position correction.
        If w_des cannot be allocated, priorities apply: the feed-forward, then the attitude
        correction, then the position correction, each scaled down (direction kept) until it fits
        (ratio test). If the feed-forward itself cannot be allocated, the bounded least-squares
        allocation minimising the acceleration error |M^-1 (A u - w_des)|.
        """
        u = self.exact(w_des)
        if u is not None:
            return u, True
        u_ff = self.exact(w_ff)
        if u_ff is None:
            from scipy.optimize import lsq_linear

            res = lsq_linear(self.MinvA, self.Minv @ w_des, bounds=(0.0, self.f_max), method="bvls")
            return np.clip(res.x, 0.0, self.f_max), False
        u_att = self.exact(w_ff + w_att)
        if u_att is None:
            return self._scaled(u_ff, w_att), False
        return self._scaled(u_att, w_des - w_ff - w_att), False


def run_hover(
    structure: Structure | SimModel,
    wrenches: np.ndarray,
    f_max: float = 1.0,
    seconds_per_wrench: float = 2.0,
    control_hz: float = 500.0,
    gains: HoverGains | None = None,
    takeoff_seconds: float = 2.0,
    initial_offset: tuple[float, float, float] = (0.03, -0.02, 0.02),
    initial_tilt_rad: float = 0.05,
    settle_fraction: float = 0.3,
    drift_limit_m: float = 1.0,
    drift_limit_rad: float = 1.0,
    recover_limit_m: float = 0.1,
    known_load: bool = True,
    load_frame: str = "world",
    load_ramp_seconds: float = 1.0,
    load_ramp_profile: str = "cosine",
) -> HoverResult:
    """Fly the structure and hold its pose against each task wrench's load (module docstring).

    The run starts with a take-off segment (index -1, ``takeoff_seconds`` long, not part of the
    task metrics): the structure starts ``initial_offset`` away from the reference and tilted by
    ``initial_tilt_rad``, and hovers at half thrust (w = A 1 f_max / 2, the centre of the
    feasible set) until it has converged. Then each task wrench is held in turn.

    The external load is ``d = -(w + gravity wrench)``: at equilibrium the rotors produce exactly
    the task wrench w (``load_frame`` says whether d stays fixed in the world or follows the body).

    Args:
        structure: a structure, or a flight model from ``build_model(..., bench=False)``.
        wrenches: (t, 6) task wrenches in {S} (the total the rotors must produce).
        f_max: rotor thrust limit (ignored when a model is given).
        seconds_per_wrench: simulated seconds per segment.
        control_hz: controller rate; must divide the physics rate (1 / timestep).
        gains: controller tuning (default :class:`HoverGains`).
        takeoff_seconds: length of the take-off segment (0 skips it and the perturbation).
        initial_offset: start position minus the reference, metres (world frame).
        initial_tilt_rad: start tilt about the axis (1, 1, 0) / sqrt(2).
        settle_fraction: the last fraction of each segment over which errors are measured.
        drift_limit_m: position error that ends a segment as diverged.
        drift_limit_rad: attitude error that ends a segment as diverged.
        recover_limit_m: a segment that runs its course but ends with a position error above
            this is marked diverged too (it did not recover); either way the next segment starts
            from the hover equilibrium (module docstring).
        known_load: the controller is told each task wrench (feed-forward); False: it is not, and
            a load observer plus integral action estimate the load (it knows only the take-off
            trim), see :class:`HoverGains` ``omega_obs``.
        load_frame: ``"world"`` (default) or ``"body"``, see :data:`LOAD_FRAMES`.
        load_ramp_seconds: unknown load only: the load goes from the previous task wrench's load
            to the next one's over this many seconds at the start of each segment (0: a step).
            Must leave the settled part of the segment alone: at most
            ``(1 - settle_fraction) * seconds_per_wrench``. Ignored with a known load (a step).
        load_ramp_profile: ``"cosine"`` (default; ``(1 - cos(pi s)) / 2``, no jump in the load's
            rate at either end) or ``"linear"``, see :data:`LOAD_RAMP_PROFILES`.
    """
    import mujoco

    W = check_wrenches(wrenches)
    if isinstance(structure, SimModel):
        sim = structure
        if sim.bench:
            raise ValueError("run_hover needs a flight model (bench=False): the bench is welded")
    else:
        sim = build_model(structure, check_f_max(f_max), bench=False)
    if not (seconds_per_wrench > 0 and 0 < settle_fraction <= 1 and control_hz > 0):
        raise ValueError(
            f"need seconds_per_wrench > 0, 0 < settle_fraction <= 1, control_hz > 0; got "
            f"{seconds_per_wrench}, {settle_fraction}, {control_hz}"
        )
    if not recover_limit_m > 0:
        raise ValueError(f"recover_limit_m must be > 0, got {recover_limit_m}")
    if not takeoff_seconds >= 0:
        raise ValueError(f"takeoff_seconds must be >= 0, got {takeoff_seconds}")
    if load_frame not in LOAD_FRAMES:
        raise ValueError(f"load_frame must be one of {LOAD_FRAMES}, got {load_frame!r}")
    if load_ramp_profile not in LOAD_RAMP_PROFILES:
        raise ValueError(
            f"load_ramp_profile must be one of {LOAD_RAMP_PROFILES}, got {load_ramp_profile!r}"
        )
    ramp_s = 0.0 if known_load else float(load_ramp_seconds)
    if not ramp_s >= 0:
        raise ValueError(f"load_ramp_seconds must be >= 0, got {load_ramp_seconds}")
    if ramp_s > (1.0 - settle_fraction) * seconds_per_wrench + 1e-9:
        raise ValueError(
            f"load_ramp_seconds {ramp_s:g} reaches into the settled part of the segment: need "
            f"<= (1 - settle_fraction) * seconds_per_wrench = "
            f"{(1.0 - settle_fraction) * seconds_per_wrench:g}"
        )
    model = sim.model
    dt = model.opt.timestep
    substeps = round(1.0 / (control_hz * dt))
    if substeps < 1 or abs(substeps * control_hz * dt - 1.0) > 1e-9:
        raise ValueError(f"control_hz {control_hz} must divide the physics rate {1 / dt:g} Hz")
    ctrl_dt = 1.0 / control_hz
    n_ctrl = max(1, round(seconds_per_wrench * control_hz))
    n_takeoff = round(takeoff_seconds * control_hz)
    n_settled = max(1, round(settle_fraction * n_ctrl))
    gains = gains or HoverGains()
    m = sim.mass
    J = body_inertia(sim)
    A = sim.A
    g_world = np.array(model.opt.gravity)
    kp_p, kd_p = gains.omega_pos**2, 2 * gains.damping * gains.omega_pos
    kp_r, kd_r = gains.omega_att**2, 2 * gains.damping * gains.omega_att
    ki_p, ki_r = gains.omega_int * kp_p, gains.omega_int * kp_r
    p_ref = np.array([0.0, 0.0, HOME_HEIGHT])
    Minv = np.zeros((6, 6))
    Minv[:3, :3] = np.eye(3) / m
    Minv[3:, 3:] = np.linalg.inv(J)
    alloc = _Allocator(A, sim.f_max, Minv)
    P = A @ alloc.pinv  # projection onto range(A)
    b = sim.body_id
    tol = TOL * sim.f_max
    w_trim = A.sum(axis=1) * sim.f_max / 2.0

    data = mujoco.MjData(model)

    def reset(perturb: bool) -> None:
        mujoco.mj_resetData(model, data)
        if perturb:
            data.qpos[:3] = p_ref + np.asarray(initial_offset, dtype=float)
            half = 0.5 * initial_tilt_rad
            axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
            data.qpos[3:7] = np.concatenate([[math.cos(half)], math.sin(half) * axis])
        mujoco.mj_forward(model, data)

    def design(w: np.ndarray) -> _Design:
        return _design(A, w, m, J, gains, load_frame, integral=not known_load)

    # segments: (index, wrench, control steps); -1 is the take-off at half thrust
    segments = [(i, w, n_ctrl) for i, w in enumerate(W)]
    if n_takeoff > 0:
        segments.insert(0, (-1, w_trim, n_takeoff))
    reset(perturb=n_takeoff > 0)
    total = sum(n for _, _, n in segments)
    rec_t = np.full(total, np.nan)
    rec_seg = np.concatenate([np.full(n, i) for i, _, n in segments])
    rec_pos = np.full(total, np.nan)
    rec_att = np.full(total, np.nan)
    rec_u = np.full((total, sim.n_rotors), np.nan)
    rec_load = np.full((total, 6), np.nan)
    rec_est = np.full((total, 6), np.nan)
    rec_sat = np.zeros(total, dtype=bool)
    settled = np.zeros(total, dtype=bool)
    gammas = np.empty(len(W))
    diverged = np.zeros(len(W), dtype=bool)
    metrics = []

    # unknown load: the estimate w_obs + w_hat (observer + integral action) and its gains
    # persist across segments (no switch is announced); it starts at the take-off trim
    observer = gains.omega_obs > 0
    obs_gain = 1.0 - math.exp(-gains.omega_obs * ctrl_dt)  # first-order low-pass per step
    w_obs = w_trim.copy() if observer else np.zeros(6)
    w_hat = w_trim - w_obs
    alloc.recentre(w_trim)
    des = design(w_trim)
    t_design = 0.0
    w_prev = w_trim
    last = None  # (v, omega, u, R) of the previous control step, for the observer
    k = 0
    for i, w, n_steps in segments:
        if known_load:
            gamma = alloc.recentre(w)
            des = design(w)
        else:
            gamma = allocate(A, w, sim.f_max)[1]  # for the report only, the controller is blind
        # unknown load: ramp from the previous segment's load (none for the take-off)
        n_ramp = min(round(ramp_s * control_hz), n_steps) if i >= 0 else 0
        w_from = w_prev
        w_load = w
        kinds = {des.kind}
        start = k
        cut = None
        for step in range(n_steps):
            if step < n_ramp:
                frac = _ramp_fraction((step + 1) / n_ramp, load_ramp_profile)
                w_load = w_from + frac * (w - w_from)
            else:
                w_load = w
            if load_frame == "world" and step <= n_ramp:  # d = -(w + gravity), world-fixed
                data.xfrc_applied[b, :3] = -w_load[:3] - m * g_world
                data.xfrc_applied[b, 3:] = -w_load[3:]
            t_now = (start + step) * ctrl_dt
            if not known_load and t_now - t_design >= _RESCHEDULE_S - 1e-12:
                w_est = w_obs + w_hat
                if np.linalg.norm(w_est - des.w) > _RESCHEDULE_REL * np.linalg.norm(des.w):
                    des = design(w_est.copy())
                    alloc.recentre(w_est)
                    kinds.add(des.kind)
                    t_design = t_now
            R = body_rotation(sim, data)
            p = np.array(data.xpos[b])
            v = np.array(data.qvel[:3])
            omega = np.array(data.qvel[3:6])
            e_p = p - p_ref
            theta = rotation_vector(R)
            if not known_load and observer and last is not None:
                # the wrench the rotors would have needed for no acceleration over the last step
                v0, om0, u0, R0 = last
                om = 0.5 * (omega + om0)
                acc = np.concatenate(
                    [m * (R0.T @ (v - v0)), J @ (omega - om0) + ctrl_dt * _cross(om, J @ om)]
                )
                w_obs = w_obs + obs_gain * (P @ (A @ u0 - acc / ctrl_dt) - w_obs)
            w_ff = w if known_load else w_obs + w_hat
            gyro = P @ np.concatenate([np.zeros(3), _cross(omega, J @ omega)])
            if des.kind == "lqr":
                w_att = A @ (-des.K[:, 3:6] @ theta - des.K[:, 9:] @ omega) + gyro
                w_pos = A @ (-des.K[:, :3] @ e_p - des.K[:, 6:9] @ v)
            else:
                f_corr = R.T @ (m * (-kp_p * e_p - kd_p * v))
                t_corr = J @ (-kp_r * theta - kd_r * omega)
                w_att = P @ np.concatenate([np.zeros(3), t_corr]) + gyro
                w_pos = P @ np.concatenate([f_corr, np.zeros(3)])
            w_des = w_ff + w_att + w_pos
            u, exact = alloc(w_des, w_ff, w_att)
            data.ctrl[:] = u
            last = (v, omega, u, R)
            if load_frame == "body":  # d = -(w + gravity wrench), w following the body
                data.xfrc_applied[b, :3] = -(R @ w_load[:3]) - m * g_world
                data.xfrc_applied[b, 3:] = -(R @ w_load[3:])
            if not known_load:  # integral action with anti-windup (module docstring)
                if des.kind == "lqr":
                    e = np.concatenate([e_p, theta])
                    w_next = w_hat - ctrl_dt * (A @ (des.Ki @ (des.C @ e)))
                else:
                    c = np.concatenate([R.T @ (-m * ki_p * e_p), J @ (-ki_r * theta)])
                    w_next = w_hat + ctrl_dt * (P @ c)
                if exact or (not observer and alloc.exact(w_next) is not None):
                    w_hat = w_next
            mujoco.mj_step(model, data, nstep=substeps)
            pos_err = float(np.linalg.norm(p_ref - data.xpos[b]))
            att_err = rotation_angle(body_rotation(sim, data))
            rec_t[k] = (start + step + 1) * ctrl_dt
            rec_pos[k] = pos_err
            rec_att[k] = att_err
            rec_u[k] = u
            rec_load[k] = w_load
            rec_est[k] = w_ff
            rec_sat[k] = bool(np.any((u <= tol) | (u >= sim.f_max - tol)))
            settled[k] = step >= n_steps - n_settled
            k += 1
            if not (np.isfinite(pos_err) and np.isfinite(att_err)):
                cut = "non-finite state"
            elif pos_err > drift_limit_m:
                cut = f"position error passed {drift_limit_m:g} m"
            elif att_err > drift_limit_rad:
                cut = f"attitude error passed {drift_limit_rad:g} rad"
            if cut:
                break
        cut_short = cut is not None
        if cut_short:
            settled[start:k] = True  # a diverged segment counts in full
        elif pos_err > recover_limit_m:  # ran its course but did not come back: diverged too
            cut = f"ended {pos_err:.3g} m away (not back within {recover_limit_m:g} m)"
        seg = slice(start, k)
        window = settled[seg]
        est_err = headroom = None
        if not known_load:
            est_err = float(np.linalg.norm(w_obs + w_hat - w) / max(float(np.linalg.norm(w)), 1e-9))
            if i >= 0:
                headroom = step_headroom(A, w, w_prev, sim.f_max)
        metrics.append(
            {
                "segment": i,
                "gamma": float(gamma) if np.isfinite(gamma) else None,
                "controller": "+".join(sorted(kinds)),
                "diverged": bool(cut),
                "stop_reason": cut,
                "stop_time_s": float((k - start) * ctrl_dt) if cut_short else None,
                "max_position_error_m": float(np.nanmax(rec_pos[seg][window])),
                "max_attitude_error_rad": float(np.nanmax(rec_att[seg][window])),
                "saturated_fraction": float(rec_sat[seg].mean()),
                "settled_saturated_fraction": float(rec_sat[seg][window].mean()),
                "load_estimate_error": est_err,
                "step_headroom": headroom,
            }
        )
        # after a divergence: restart at rest at home, at the hover equilibrium of this
        # segment's load if it has one (the state a settled segment would have left), else at
        # the take-off trim; the next segment's load then changes from that equilibrium's load
        at_rest = math.isfinite(gamma) and gamma <= 1.0 + TOL
        w_prev = w_trim if cut and not at_rest else w
        if i >= 0:
            gammas[i] = gamma
            diverged[i] = bool(cut)
        if cut:
            k = start + n_steps
            reset(perturb=False)
            if not known_load:
                w_obs = w_prev.copy() if observer else np.zeros(6)
                w_hat = w_prev - w_obs
                last = None
                alloc.recentre(w_prev)
                des = design(w_prev.copy())
                t_design = k * ctrl_dt
    keep = ~np.isnan(rec_t)
    task = rec_seg >= 0
    return HoverResult(
        wrenches=W,
        f_max=sim.f_max,
        known_load=known_load,
        load_frame=load_frame,
        time=rec_t[keep],
        segment=rec_seg[keep],
        position_error=rec_pos[keep],
        attitude_error=rec_att[keep],
        u=rec_u[keep],
        saturated=rec_sat[keep],
        settled=(settled & task)[keep],
        gamma=gammas,
        feasible=np.asarray(feasible(A, W, sim.f_max), dtype=bool),
        diverged=diverged,
        load=rec_load[keep],
        load_estimate=rec_est[keep],
        segment_metrics=metrics,
        load_ramp_seconds=ramp_s,
        load_ramp_profile=load_ramp_profile,
    )
