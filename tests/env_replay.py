"""Seeded episodes of the assembly environment, recorded to ``tests/data/env_replay.npz``.

The replay test (``test_env_replay.py``) plays the same episodes with the current code and
compares observations, rewards, end flags and selected info entries with the recording: discrete
entries exactly, floating-point ones within the tolerances it states (bit for bit only between
two runs on one machine).
Re-record only for a deliberate behaviour change, said in ``CHANGELOG.md`` (a change of the
episodes themselves needs a new version id): ``PYTHONPATH=$PWD python tests/env_replay.py``.
Last re-recorded when terminal masks stopped being all zero: every other entry of every event
was unchanged, and the masks and lookahead rows changed on terminal events only.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

import modquad_gym  # noqa: F401  (registers the environments)
from modquad_gym.tasks import PaperTasks, PlantedTasks, TaskRequirement, make_generator

DATA = Path(__file__).parent / "data" / "env_replay.npz"
STEPS = 120
"""Events (resets and steps) recorded per configuration."""


def _external(rng: np.random.Generator) -> TaskRequirement:
    """A fifth of a paper task's wrenches as an external task (self-weight added by the env)."""
    task = PaperTasks()(rng)
    return TaskRequirement(0.2 * task.wrenches, name="ext", f_max=task.f_max, kind="external")


_FIXED = [PlantedTasks(n_wrenches=6)(np.random.default_rng(i)) for i in range(3)]

CONFIGS: dict[str, dict] = {
    "default": {},
    "default_lookahead": {"lookahead": True},
    "paper": {"tasks": "paper", "n_max": 5},
    "planted_terminate": {"tasks": "planted", "invalid_action": "terminate"},
    "screwdriver_lookahead": {"tasks": "screwdriver", "lookahead": True, "n_max": 6},
    "weights_fmax": {"reward_weights": {"w_module": 0.3}, "f_max": 3.0, "tasks": "paper"},
    # the source itself, not the name "mixed": at n_max 5 the name caps its planted sizes (2-6)
    # at 5, and the recording was made before that cap (its sources' draws at their own sizes)
    "mixed_modules": {"modules": "t45,t45m,flat", "n_max": 5, "tasks": make_generator("mixed")},
    "fixed_list": {"tasks": _FIXED, "lookahead": True},
    "external_modules": {"modules": "t45,flat", "tasks": _external, "n_max": 5},
    "mixed_modules_lookahead": {"modules": "t45,flat", "lookahead": True, "initial_type": "random"},
    "faces": {"actions": "faces", "tasks": "planted-large", "n_max": 12},
    "faces_mixed_lookahead": {"actions": "faces", "modules": "t45,flat", "lookahead": True},
}
INFO_KEYS = (
    "n_modules",
    "satisfied_fraction",
    "success",
    "is_success",
    "evaluated",
    "oracle_calls",
    "invalid_action",
    "n_wrenches",
)


def _action(rng: np.random.Generator, mask: np.ndarray, occupancy: np.ndarray | None, n: int):
    """A random valid action mostly; sometimes an occupied cell (the faces encoding: an empty
    slot), a non-adjacent cell or junk."""
    u = rng.random()
    valid = np.flatnonzero(mask)
    if u < 0.8 and len(valid):
        return int(valid[rng.integers(len(valid))])
    if u < 0.88:
        full = mask == 0 if occupancy is None else np.tile(occupancy, n // len(occupancy))
        occ = np.flatnonzero(full)
        return int(occ[rng.integers(len(occ))])
    if u < 0.95:
        return int(rng.integers(n))
    return [-1, n, 2.5, None][int(rng.integers(4))]


def play(name: str, steps: int = STEPS) -> dict[str, np.ndarray]:
    """The events of configuration ``name``: arrays keyed ``name/<field>``, one row per event."""
    env = gym.make("modquad_gym:ModQuadAssembly-v0", **CONFIGS[name])
    rng = np.random.default_rng(len(name))
    rows: dict[str, list] = {}

    def record(obs, reward, terminated, truncated, info, is_reset):
        for k, v in obs.items():
            rows.setdefault(f"obs_{k}", []).append(np.asarray(v).copy())
        rows.setdefault("reward", []).append(reward)
        rows.setdefault("terminated", []).append(terminated)
        rows.setdefault("truncated", []).append(truncated)
        rows.setdefault("is_reset", []).append(is_reset)
        for k in INFO_KEYS:
            rows.setdefault(f"info_{k}", []).append(info[k])
        rows.setdefault("info_mask", []).append(np.asarray(info["action_mask"]).copy())
        rows.setdefault("info_terms", []).append(list(info["reward_terms"].values()))
        cells = np.zeros((16, 2), dtype=np.int64)
        cells[: len(info["cells"])] = info["cells"]
        rows.setdefault("info_cells", []).append(cells)
        if "mass_kg" in info:
            rows.setdefault("info_mass_kg", []).append(info["mass_kg"])

    obs, info = env.reset(seed=7 + len(name))
    record(obs, 0.0, False, False, info, True)
    n = int(env.action_space.n)
    for _ in range(steps - 1):
        a = _action(rng, obs["action_mask"], obs.get("occupancy"), n)
        obs, reward, terminated, truncated, info = env.step(a)
        record(obs, reward, terminated, truncated, info, False)
        if terminated or truncated:
            obs, info = env.reset()
            record(obs, 0.0, False, False, info, True)
    env.close()
    return {f"{name}/{k}": np.array(v) for k, v in rows.items()}


def record_all() -> dict[str, np.ndarray]:
    """Every configuration's events in one dict."""
    out: dict[str, np.ndarray] = {}
    for name in CONFIGS:
        out.update(play(name))
    return out


if __name__ == "__main__":
    DATA.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(DATA, **record_all())
    print(f"wrote {DATA}")
