"""The wrench test stand (the "bench" of `validate` and its JSON keys): bolt the structure to a
wall through a load cell and measure what it produces.

The paper (Sec. VI) connects the structure's COM to a static wall through a CoppeliaSim force
sensor. Copied literally into MuJoCo, a body with no joint welded to the world has nv = 0: its
actuators do nothing and its sensors read gravity only. The setup here is one whose readings are
checked against A u (tests/test_sim.py):

* the structure is a *free* body (six DOF, so the actuators act on it);
* a light child body ``load_cell`` sits at the COM, rigidly attached to the structure, and a weld
  equality bolts ``load_cell`` to the world (the wall);
* MuJoCo force/torque sensors on the ``load_cell`` site (at the COM, axes of {S}) read the wrench
  that the structure transmits into the load cell.

For each task wrench the rotor inputs u are set, the model is stepped until it is static again
(the weld is a stiff but soft constraint, so the structure settles by micrometres), and the sensors
are read. At rest the structure's balance is ``0 = A u + m g + F_cell->S``, so the load cell reads
``A u + m g`` expressed in its own frame. Gravity stays on (a real bench) and the structure's known
weight ``m g`` (rotated into the sensor frame, zero torque about the COM) is subtracted. What is
left is the rotors' wrench in {S}, about the COM.

Two allocations are compared: ``"exact"``, the oracle's most centred exact allocation
(:func:`modquad_gym.oracle.allocate`), and ``"pinv_clip"``, the paper's ``clip(A^+ w, 0, f_max)``,
which can miss a feasible wrench whenever A^+ w leaves the box.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from modquad_gym.core.extras import import_optional
from modquad_gym.core.validation import check_f_max
from modquad_gym.geometry.structure import Structure
from modquad_gym.oracle import TOL, allocate, check_wrenches, feasible
from modquad_gym.sim.model import SimModel, build_model

ALLOCATIONS = ("exact", "pinv_clip")

_CHUNK = 50  # steps between two readings while settling


@dataclass(frozen=True)
class BenchResult:
    """Bench readings for t task wrenches under one allocation.

    Attributes:
        allocation: ``"exact"`` or ``"pinv_clip"``.
        f_max: rotor thrust limit.
        commanded: (t, 6) task wrenches w.
        u: (t, 4n) rotor inputs applied.
        produced: (t, 6) A u, what the inputs should produce.
        measured: (t, 6) load-cell wrench minus the structure's weight, in {S} about the COM.
        feasible: (t,) the oracle's verdict for each w.
        steps: (t,) simulation steps taken to settle after each change of inputs.
    """

    allocation: str
    f_max: float
    commanded: np.ndarray
    u: np.ndarray
    produced: np.ndarray
    measured: np.ndarray
    feasible: np.ndarray
    steps: np.ndarray

    @property
    def relative_error(self) -> np.ndarray:
        """(t,) |measured - w| / |w| (|w| floored at 1e-6 f_max so w = 0 is well defined)."""
        return _relative(self.measured - self.commanded, self.commanded, self.f_max)

    @property
    def sensor_error(self) -> np.ndarray:
        """(t,) |measured - A u| / |A u|: how faithfully the bench reads what the rotors make."""
        return _relative(self.measured - self.produced, self.produced, self.f_max)

    @property
    def max_error(self) -> float:
        return float(self.relative_error.max(initial=0.0))

    @property
    def max_sensor_error(self) -> float:
        return float(self.sensor_error.max(initial=0.0))

    @property
    def at_limit(self) -> np.ndarray:
        """(t,) True when some rotor sits at 0 or f_max (within 1e-6 f_max)."""
        tol = TOL * self.f_max
        return np.any((self.u <= tol) | (self.u >= self.f_max - tol), axis=1)


def _relative(diff: np.ndarray, ref: np.ndarray, f_max: float) -> np.ndarray:
    denom = np.maximum(np.linalg.norm(ref, axis=1), 1e-6 * f_max)
    return np.linalg.norm(diff, axis=1) / denom


def allocate_inputs(A: np.ndarray, W: np.ndarray, f_max: float, allocation: str) -> np.ndarray:
    """(t, 4n) rotor inputs for each row of W by ``"exact"`` or ``"pinv_clip"`` (module doc)."""
    W = check_wrenches(W)
    if allocation == "exact":
        return np.array([allocate(A, w, f_max)[0] for w in W]).reshape(len(W), A.shape[1])
    if allocation == "pinv_clip":
        return np.clip(W @ np.linalg.pinv(A).T, 0.0, f_max)
    raise ValueError(f"unknown allocation {allocation!r}; choose one of {', '.join(ALLOCATIONS)}")


def settle(sim: SimModel, data, max_steps: int = 20000, rtol: float = 1e-13) -> int:
    """Step until the load-cell reading stops changing (relative ``rtol``); return the steps."""
    mujoco = import_optional("mujoco")

    prev = np.array(data.sensordata)
    steps = 0
    while steps < max_steps:
        mujoco.mj_step(sim.model, data, nstep=_CHUNK)
        steps += _CHUNK
        mujoco.mj_forward(sim.model, data)
        now = np.array(data.sensordata)
        if np.linalg.norm(now - prev) <= rtol * (1.0 + np.linalg.norm(now)):
            return steps
        prev = now
    return steps


def read_load_cell(sim: SimModel, data) -> np.ndarray:
    """The rotors' wrench in {S} from the load cell: reading minus the structure's weight."""
    mujoco = import_optional("mujoco")

    site = mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_SITE, "load_cell")
    R = np.array(data.site_xmat[site]).reshape(3, 3)
    raw = np.array(data.sensordata[:6])
    weight = R.T @ (sim.mass * np.array(sim.model.opt.gravity))
    return np.concatenate([raw[:3] - weight, raw[3:]])


def run_bench(
    structure: Structure | SimModel,
    wrenches: np.ndarray,
    f_max: float = 1.0,
    allocation: str = "exact",
    max_steps: int = 20000,
) -> BenchResult:
    """Command each task wrench on the wall-mounted structure and measure it (module docstring).

    Args:
        structure: a structure, or a bench model from ``build_model(..., bench=True)``.
        wrenches: (t, 6) task wrenches [f; tau] in {S}, the total the rotors must produce.
        f_max: rotor thrust limit (ignored when a model is given: the model's own is used).
        allocation: ``"exact"`` (oracle) or ``"pinv_clip"`` (the paper's).
        max_steps: cap on the settling steps per wrench.
    """
    W = check_wrenches(wrenches)
    if isinstance(structure, SimModel):
        sim = structure
        if not sim.bench:
            raise ValueError("run_bench needs a model built with bench=True (load cell and weld)")
    else:
        sim = build_model(structure, check_f_max(f_max), bench=True)
    U = allocate_inputs(sim.A, W, sim.f_max, allocation)
    data = sim.new_data()
    measured = np.empty_like(W)
    steps = np.zeros(len(W), dtype=int)
    for i, u in enumerate(U):
        data.ctrl[:] = u
        steps[i] = settle(sim, data, max_steps)
        measured[i] = read_load_cell(sim, data)
    return BenchResult(
        allocation=allocation,
        f_max=sim.f_max,
        commanded=W,
        u=U,
        produced=U @ sim.A.T,
        measured=measured,
        feasible=np.asarray(feasible(sim.A, W, sim.f_max), dtype=bool),
        steps=steps,
    )
