"""The size-free policy's actor in NumPy: a saved model acts without torch.

:class:`~modquad_gym.policy.network.CandidateScorer` gives one logit per valid action; a solver
needs nothing else (not the critic, not SB3's distribution). :func:`export` writes the actor's
weights beside a saved model (``model_actor.npz`` next to ``model.zip``: one per model, since a
training folder holds several) with the SHA-256 of the ``model.zip`` they came from and that of
its own arrays; :func:`exported` reads them back only while both still match (a model.zip
replaced since, or arrays edited and saved again with the same shapes, are never acted on: the
caller uses torch instead, :func:`inference_model`). :class:`Actor` is the forward pass,
computed for the valid actions only. The digests catch stale and edited files, not forgery: a
file whose arrays and digest are both rewritten is read as written.

Float32 throughout, as the torch network computes: the weights were trained in float32, a
float64 pass would differ from torch's by the same ~1e-6, and float32 halves the memory traffic.
Loading NumPy weights costs no torch import (about 220 MB and a second at start).
"""

from __future__ import annotations

import hashlib
import math
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.envs.assembly.features import STRUCTURE_SCALARS, TASK_SCALARS
from modquad_gym.policy.models import read_config

TYPE_FEATURES = 7
"""Per module type: its rotors' mean wrench column (6, at f_max, torques per metre of side) and
its mass in units of 0.3 kg."""
LAYERS = ("context.0", "context.2", "embed.0", "embed.2", "mix", "score_cell", "score_pool",
          "score_out")  # fmt: skip
"""The scorer's linear layers the actor uses (the critic's are left out)."""
SPACE_KEYS = ("occupancy", "task", "structure", "candidates", "action_mask")
"""The observation entries whose widths the export keeps (the environment they imply)."""
EXPORT_KEYS = {f"{name}.{p}" for name in LAYERS for p in ("weight", "bias")} | {
    f"width.{k}" for k in SPACE_KEYS} | {"types", "hidden", "model_sha256",
                                         "actor_sha256"}  # fmt: skip
"""The arrays an export holds, no more (a file with others was not written by :func:`export`)."""


def type_features(modules) -> list[list[float]]:
    """The descriptor of each module type (see :data:`TYPE_FEATURES`): plain lists, so they
    go into a model's saved keywords."""
    out = []
    for m in modules:
        col = np.asarray(m.columns, dtype=float).mean(axis=1)
        col[3:] /= float(m.side)
        out.append([*col.round(12).tolist(), round(float(m.mass) / 0.3, 12)])
    return out


def scaled_entries(k: int) -> tuple[np.ndarray, np.ndarray]:
    """bool masks of the task (K + 7) and structure (2K + 7) entries that the environment
    divides by n_max (capabilities, deficits, counts); the others are shares and ranks."""
    task = np.ones(k + TASK_SCALARS, dtype=bool)
    task[-1] = False  # log(1 + t)
    structure = np.ones(2 * k + STRUCTURE_SCALARS, dtype=bool)
    structure[[2 * k, 2 * k + 2, 2 * k + 3]] = False  # satisfied share, rank / 6, covered share
    return task, structure


def symlog(x: np.ndarray) -> np.ndarray:
    return np.sign(x) * np.log1p(np.abs(x))


def file_hash(path: Path) -> str:
    """The SHA-256 of the file at ``path`` (hex)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def arrays_hash(arrays: dict) -> str:
    """The SHA-256 (hex) of an export's arrays but its two digests: each one's name, dtype,
    shape and bytes, in name order."""
    h = hashlib.sha256()
    for key in sorted(set(arrays) - {"model_sha256", "actor_sha256"}):
        value = np.ascontiguousarray(arrays[key])
        h.update(f"{key}:{value.dtype.str}:{value.shape};".encode())
        h.update(value.tobytes())
    return h.hexdigest()


class Actor:
    """The scorer's logits for the valid actions of one observation, in NumPy (float32).

    Args:
        weights: ``"<layer>.weight"`` and ``"<layer>.bias"`` of every layer in :data:`LAYERS`.
        types: the module types' descriptors (:func:`type_features`), one row per type.
    """

    def __init__(self, weights: dict[str, np.ndarray], types: Any) -> None:
        self.layers = {
            name: (np.ascontiguousarray(np.asarray(weights[f"{name}.weight"], np.float32).T),
                   np.asarray(weights[f"{name}.bias"], np.float32))
            for name in LAYERS
        }  # fmt: skip
        self.types = np.asarray(types, dtype=np.float32).reshape(-1, TYPE_FEATURES)
        self.hidden = self.layers["mix"][1].shape[0]
        self.width = self.layers["embed.0"][0].shape[0] - 9 - 2 - TYPE_FEATURES
        self.k = (self.layers["context.0"][0].shape[0] - TASK_SCALARS - STRUCTURE_SCALARS - 1) // 3
        self.task_scaled, self.structure_scaled = scaled_entries(self.k)

    def linear(self, name: str, x: np.ndarray) -> np.ndarray:
        weight, bias = self.layers[name]
        return x @ weight + bias

    def logits(self, obs: dict, valid: np.ndarray) -> np.ndarray:
        """float32 (len(valid),): the logits of the actions ``valid`` (indices) at ``obs``."""
        occupancy = np.asarray(obs["occupancy"], dtype=np.float32)
        n_cells = occupancy.shape[0]
        side = math.isqrt(n_cells)
        n_max = (side + 1) / 2
        n_modules = occupancy.sum(dtype=np.float32)
        task = np.asarray(obs["task"], dtype=np.float32)
        structure = np.asarray(obs["structure"], dtype=np.float32)
        task = np.where(self.task_scaled, task * n_max, task)
        structure = np.where(self.structure_scaled, structure * n_max, structure)
        summary = symlog(np.concatenate([task, structure, [n_modules]]).astype(np.float32))
        context = self.linear("context.2", np.maximum(self.linear("context.0", summary), 0))
        embedded = np.maximum(self.embed(self.inputs(obs, occupancy, valid)) +
                              self.linear("mix", context), 0)  # fmt: skip
        pooled = np.concatenate([embedded.mean(axis=0), embedded.max(axis=0)])
        hidden = self.linear("score_cell", embedded) + self.linear("score_pool", pooled)
        return self.linear("score_out", np.maximum(hidden, 0))[:, 0]

    def embed(self, x: np.ndarray) -> np.ndarray:
        return self.linear("embed.2", np.maximum(self.linear("embed.0", x), 0))

    def inputs(self, obs: dict, occupancy: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """(len(valid), width + 18): each action's lookahead row (support entries
        de-normalised), the 3 x 3 occupancy around its cell, its offset from the structure's
        centre and its module type's descriptor (as ``CandidateScorer.cell_inputs``)."""
        n_cells = occupancy.shape[0]
        side = math.isqrt(n_cells)
        n_max = (side + 1) / 2
        candidates = np.asarray(obs["candidates"], dtype=np.float32)
        rows = candidates.reshape(-1, self.width)[valid]
        rows = np.concatenate([symlog(rows[:, :1] * n_max), rows[:, 1:2],
                               symlog(rows[:, 2:4] * n_max), rows[:, 4:]], axis=1)  # fmt: skip
        cell, kind = valid % n_cells, valid // n_cells
        y, x = cell // side, cell % side
        padded = np.zeros((side + 2, side + 2), dtype=np.float32)  # np.pad costs 0.4 ms a call
        padded[1:-1, 1:-1] = occupancy.reshape(side, side)
        patch = np.stack([padded[y + dy, x + dx] for dy in range(3) for dx in range(3)], axis=1)
        radius = (side - 1) // 2
        occupied = np.flatnonzero(occupancy)
        weights = occupancy[occupied]
        count = max(float(weights.sum(dtype=np.float32)), 1.0)
        centre = np.array([weights @ (occupied % side - radius).astype(np.float32),
                           weights @ (occupied // side - radius).astype(np.float32)],
                          dtype=np.float32) / np.float32(count)  # fmt: skip
        xy = np.stack([x - radius, y - radius], axis=1).astype(np.float32)
        return np.concatenate([rows, patch, symlog(xy - centre), self.types[kind]], axis=1)

    def probabilities(self, obs: dict, mask: np.ndarray) -> np.ndarray:
        """float64 action probabilities at ``obs``: a softmax over the valid actions of
        ``mask``, zero elsewhere (all zero when none is valid)."""
        mask = np.asarray(mask, dtype=bool)
        valid = np.flatnonzero(mask)
        probs = np.zeros(mask.shape[0])
        if valid.size:
            z = self.logits(obs, valid).astype(np.float64)
            e = np.exp(z - z.max())
            probs[valid] = e / e.sum()
        return probs

    def greedy(self, obs: dict, mask: np.ndarray) -> int:
        """The valid action of the largest logit (the first of ties; 0 when none is valid, as
        SB3's masked distribution gives)."""
        valid = np.flatnonzero(np.asarray(mask, dtype=bool))
        return int(valid[np.argmax(self.logits(obs, valid))]) if valid.size else 0


@dataclass(frozen=True)
class ExportedModel:
    """A model's exported actor: what :class:`~modquad_gym.policy.policy.Policy` needs in place
    of the saved MaskablePPO (the same fields as :class:`~.models.SavedModel` it reads)."""

    path: Path
    weights: dict
    types: list
    hidden: int
    widths: dict
    config: dict
    size_free = True

    @property
    def observation_space(self) -> Any:
        """The saved observation space's shape (Boxes of the saved widths: the environment
        keywords that :func:`~modquad_gym.policy.policy.env_kwargs_of` infers)."""
        from gymnasium import spaces

        return spaces.Dict({k: spaces.Box(-1.0, 1.0, (n,)) for k, n in self.widths.items()})

    def build(self, observation_space=None, action_space=None, types: Any = None) -> Actor:
        """The actor for a palette's ``types`` (default the saved ones); any spaces."""
        return Actor(self.weights, self.types if types is None else types)


def export_path(model_path: str | Path) -> Path:
    """Where the actor of the model at ``model_path`` is exported (``<stem>_actor.npz``)."""
    path = Path(model_path)
    return path.with_name(f"{path.stem}_actor.npz")


def exported(model_path: str | Path) -> ExportedModel | None:
    """The exported actor of the model at ``model_path`` (a model.zip), or None when there is
    none, it cannot be read, it came from another model.zip (its SHA-256 differs) or its arrays
    were edited since the export (their SHA-256 differs from the recorded one)."""
    path = Path(model_path)
    target = export_path(path)
    if not path.is_file() or not target.is_file():
        return None
    try:
        with np.load(target, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        if set(arrays) != EXPORT_KEYS or str(arrays.pop("model_sha256")) != file_hash(path):
            return None
        if str(arrays.pop("actor_sha256")) != arrays_hash(arrays):
            return None
        hidden, widths = check_export(arrays)
        types = arrays.pop("types").tolist()
        for key in ("hidden", *(f"width.{k}" for k in SPACE_KEYS)):
            arrays.pop(key)
    except (EOFError, OSError, TypeError, ValueError, zipfile.BadZipFile):
        return None
    return ExportedModel(path, arrays, types, hidden, widths, read_config(path))


def check_export(arrays: dict) -> tuple[int, dict]:
    """(hidden, widths) of an export's ``arrays``; ValueError unless its sizes are positive
    integers, its weights and types finite floats, and every layer of the shape the scorer of
    those sizes has (an edited or foreign file is never read as this network's weights)."""
    sizes = {key: arrays[key] for key in ("hidden", *(f"width.{k}" for k in SPACE_KEYS))}
    if any(v.shape != () or v.dtype.kind not in "iu" or v <= 0 for v in sizes.values()):
        raise ValueError("sizes must be positive integers")
    hidden, widths = int(sizes["hidden"]), {k: int(sizes[f"width.{k}"]) for k in SPACE_KEYS}
    k, cells, actions = widths["task"] - TASK_SCALARS, widths["occupancy"], widths["action_mask"]
    width, n_types = divmod(widths["candidates"], actions), divmod(actions, cells)
    side = math.isqrt(cells)
    if (k < 1 or widths["structure"] != 2 * k + STRUCTURE_SCALARS or width[1] or n_types[1]
            or side * side != cells or side % 2 == 0):  # fmt: skip
        raise ValueError("observation widths of no environment")
    inputs = {"context.0": widths["task"] + widths["structure"] + 1, "score_pool": 2 * hidden,
              "embed.0": width[0] + 9 + 2 + TYPE_FEATURES}  # fmt: skip
    shapes = {f"{name}.weight": (1 if name == "score_out" else hidden, inputs.get(name, hidden))
              for name in LAYERS}  # fmt: skip
    shapes.update({f"{name}.bias": shapes[f"{name}.weight"][:1] for name in LAYERS})
    shapes["types"] = (n_types[0], TYPE_FEATURES)
    for key, shape in shapes.items():
        value = arrays[key]
        if value.shape != shape or value.dtype.kind != "f" or not np.isfinite(value).all():
            raise ValueError(f"{key}: not finite floats of shape {shape}")
    return hidden, widths


def export(model_path: str | Path, trust: bool = False) -> Path | None:
    """Write the actor of the size-free model at ``model_path`` beside it (:func:`export_path`)
    and return its path; None for a model of another policy class (it acts with torch). Reads
    the model with torch (:func:`~.models.read_model`, unpickled only when ``trust``)."""
    from modquad_gym.core.outputs import atomic_write
    from modquad_gym.policy.models import read_model

    saved = read_model(model_path, trust)
    if not saved.size_free:
        return None
    prefix = "pi_features_extractor."  # the actor's (the features extractor when shared)
    arrays = {f"{name}.{p}": saved.weights[f"{prefix}{name}.{p}"].numpy()
              for name in LAYERS for p in ("weight", "bias")}  # fmt: skip
    space = saved.observation_space
    arrays.update({f"width.{k}": np.int64(space[k].shape[0]) for k in SPACE_KEYS})
    types = saved.policy_kwargs.get("types") or [[0.0] * TYPE_FEATURES]
    arrays.update(types=np.asarray(types, dtype=np.float64),
                  hidden=np.int64(saved.policy_kwargs.get("hidden", 64)),
                  model_sha256=np.str_(file_hash(saved.path)))  # fmt: skip
    arrays["actor_sha256"] = np.str_(arrays_hash(arrays))

    def write(tmp: Path) -> None:
        with tmp.open("wb") as fh:
            np.savez(fh, **arrays)

    return atomic_write(export_path(saved.path), write)


def inference_model(model_path: str | Path, trust: bool = False) -> Any:
    """What a policy acts with for the model.zip at ``model_path``: its fresh export
    (:func:`exported`), else the model read with torch (:func:`~.models.read_model`, unpickled
    only when ``trust``). Without torch, a model whose export is stale or edited is an
    ImportError naming that file."""
    from modquad_gym.policy.models import read_model

    found = exported(model_path)
    if found is not None:
        return found
    try:
        return read_model(model_path, trust)
    except ImportError as err:
        target = export_path(model_path)
        if not target.exists():
            raise
        raise ImportError(
            f"{target}: not the actor of {Path(model_path).name} (stale, edited or unreadable), "
            f"and the model itself needs torch: {err}"
        ) from None
