"""Reading a saved MaskablePPO .zip without unpickling it: what a policy acts with, as data.

SB3 saves a model as a zip: ``data`` (JSON, in which every object JSON cannot hold is a
cloudpickle under ``":serialized:"``), ``policy.pth`` (the weights) and more. Unpickling runs
whatever code the pickle names, so nothing here unpickles: the policy class is read from its
pickle's opcodes (a reference to a class, never built) and must be one of
:data:`POLICY_CLASSES`; the spaces from the text SB3 writes beside their pickles; the policy's
keywords as plain JSON; the weights with torch's ``weights_only=True``. The rest of ``data``
(schedules, buffers, anything added to the file) is never read. What cannot be read so raises
:class:`NeedsUnpicklingError` naming the entry: the caller loads it by unpickling only when the user
trusts the file (:func:`~.models.read_model`).
"""

from __future__ import annotations

import base64
import importlib
import io
import json
import pickletools
import re
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

POLICY_CLASSES = {
    ("modquad_gym.policy.network", "CandidatePolicy"),
    ("sb3_contrib.common.maskable.policies", "MaskableMultiInputActorCriticPolicy"),
}
"""(module, name) of the policy classes a model may name to be read without unpickling: the
size-free network and the masked policy of ``--architecture mlp`` (SB3's MultiInputPolicy)."""
OBSERVATION_KEYS = ("occupancy", "task", "structure", "action_mask")
"""The observation entries every model of the assembly environment reads."""
CLASS_OPS = {"PROTO", "FRAME", "SHORT_BINUNICODE", "BINUNICODE", "MEMOIZE", "STACK_GLOBAL",
             "STOP"}  # fmt: skip
"""The opcodes of a pickle that is a reference to a class and nothing else."""
DICT_TYPE = "<class 'gymnasium.spaces.dict.Dict'>"
DISCRETE_TYPE = "<class 'gymnasium.spaces.discrete.Discrete'>"
BOX = re.compile(r"'(\w+)': Box\(([-+\w.]+), ([-+\w.]+), \((\d+),\), (\w+)\)")
"""One entry of a Dict space's text: ``'name': Box(low, high, (n,), dtype)``."""


class NeedsUnpicklingError(ValueError):
    """An entry of a model's ``data`` that only unpickling can read (``what`` says which)."""

    def __init__(self, what: str) -> None:
        super().__init__(what)
        self.what = what


class NotAssemblyModelError(ValueError):
    """A saved model, but not of the assembly environment's policies (no trust helps)."""


def read_zip(path: Path) -> tuple[dict, dict]:
    """(data, weights) of the model .zip at ``path``: ``data`` as plain JSON (no entry
    deserialised), the weights of ``policy.pth`` read by torch with ``weights_only=True``."""
    import torch

    with zipfile.ZipFile(path) as archive:
        data = json.loads(archive.read("data").decode())
        if not isinstance(data, dict):
            raise ValueError("its data is not a JSON object")
        with archive.open("policy.pth") as fh:
            weights = torch.load(io.BytesIO(fh.read()), map_location="cpu", weights_only=True)
    if not isinstance(weights, dict):
        raise ValueError("its policy.pth is not a state dict")
    return data, weights


def read_safely(path: Path) -> tuple[type, dict, Any, Any, dict]:
    """(policy class, its keywords, observation space, action space, weights) of the model
    .zip at ``path``, read as the module docstring says. :class:`NotAssemblyModelError` for a
    model of another environment or algorithm, :class:`NeedsUnpicklingError` for an entry only
    unpickling reads; other ValueErrors, KeyErrors, zipfile and torch errors for a file that
    is not a saved model."""
    data, weights = read_zip(path)
    observation, action = spaces_of(data)
    policy_class = class_of(data)
    kwargs = data.get("policy_kwargs", {})
    if not isinstance(kwargs, dict) or ":serialized:" in kwargs:
        raise NeedsUnpicklingError("policy_kwargs (keywords JSON cannot hold)")
    return policy_class, dict(kwargs), observation, action, weights


def spaces_of(data: dict) -> tuple[Any, Any]:
    """The observation space (a Dict of Boxes) and action space (Discrete) of ``data``, from
    the text SB3 writes beside their pickles."""
    from gymnasium import spaces

    observation, action = data["observation_space"], data["action_space"]
    if not isinstance(observation, dict) or observation.get(":type:") != DICT_TYPE:
        raise NotAssemblyModelError(
            f"its observation space is {type_name(observation)}, not a Dict of "
            f"{', '.join(OBSERVATION_KEYS)}"
        )
    if not isinstance(action, dict) or action.get(":type:") != DISCRETE_TYPE:
        raise NotAssemblyModelError(f"its action space is {type_name(action)}, not a Discrete one")
    text = str(observation.get("spaces", ""))
    boxes = BOX.findall(text)
    if "{" + ", ".join(f"'{k}': Box({lo}, {hi}, ({n},), {t})" for k, lo, hi, n, t in boxes) + (
        "}") != text:  # fmt: skip
        raise NeedsUnpicklingError("observation_space (not a Dict of Boxes of plain bounds)")
    try:
        dict_space = spaces.Dict({key: spaces.Box(float(low), float(high), (int(n),),
                                                  np.dtype(dtype))
                                  for key, low, high, n, dtype in boxes})  # fmt: skip
        discrete = spaces.Discrete(int(action["n"]), start=int(action.get("start", 0)))
    except (TypeError, ValueError) as exc:
        raise NeedsUnpicklingError(f"observation_space or action_space ({exc})") from None
    missing = [k for k in OBSERVATION_KEYS if k not in dict_space.spaces]
    if missing:
        raise NotAssemblyModelError(f"its observations have no {', '.join(missing)}")
    return dict_space, discrete


def type_name(entry: Any) -> str:
    """The class name SB3 recorded for an entry (``<class 'a.b.Box'>`` -> ``Box``)."""
    text = entry.get(":type:", "") if isinstance(entry, dict) else type(entry).__name__
    return text.removeprefix("<class '").removesuffix("'>").rsplit(".", 1)[-1] or "unknown"


def class_of(data: dict) -> type:
    """The policy class ``data`` names, read from its pickle's opcodes (never unpickled) and
    imported only when it is one of :data:`POLICY_CLASSES`."""
    entry = data["policy_class"]
    if not isinstance(entry, dict) or not isinstance(entry.get(":serialized:"), str):
        raise ValueError("its policy_class is not a saved class")
    ops = list(pickletools.genops(base64.b64decode(entry[":serialized:"], validate=True)))
    names = [arg for op, arg, _ in ops if "UNICODE" in op.name]
    if {op.name for op, _, _ in ops} - CLASS_OPS or len(names) != 2:
        raise NeedsUnpicklingError("policy_class (a pickle that is more than a class reference)")
    module, name = names
    if (module, name) not in POLICY_CLASSES:
        raise NeedsUnpicklingError(
            f"policy_class ({module}.{name}, none of the package's policies)"
        )
    return getattr(importlib.import_module(module), name)
