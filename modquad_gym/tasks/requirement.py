"""The task requirement (paper Def. 3): a set of wrenches a structure must be able to exert,
with the per-rotor thrust limit, a kind and a name; it loads and saves task files."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from modquad_gym.core.outputs import atomic_write, check_output_file, write_text
from modquad_gym.core.validation import check_f_max, check_flag, check_task_name
from modquad_gym.dynamics.wrenches import LinearWrenches
from modquad_gym.tasks.csvfile import check_csv_header, csv_text, read_csv
from modquad_gym.tasks.examples import resolve_task_path
from modquad_gym.tasks.files import (
    SUFFIXES,
    PathLike,
    TaskFileError,
    check_meta,
    check_path,
    jsonable,
    read_json,
    read_npy,
    task_format,
    task_json,
)
from modquad_gym.tasks.wrenches import (
    DEFAULT_KIND,
    check_kind,
    check_wrench_array,
    kind_entry,
    kind_note,
    rotor_wrenches,
    rows_to_array,
    static_model,
)


@dataclass(frozen=True, eq=False)
class TaskRequirement:
    """A set of wrenches a structure must be able to exert (paper Def. 3).

    Args:
        wrenches: (t, 6) rows ``[fx, fy, fz, tx, ty, tz]`` in {S}, t >= 1, finite. Stored as a
            read-only float copy.
        name: a label for reports and file names.
        f_max: maximum thrust per rotor (> 0; normalised to 1 in the paper).
        meta: free-form JSON-serialisable extras (generator, planted cells, known optimum...);
            not part of equality.
        kind: ``"total"`` (default) or ``"external"`` (module docstring).

    Raises:
        ValueError: for a wrong shape, no wrenches, a non-finite value (naming the 1-based row),
            f_max <= 0 or an unknown kind.
    """

    wrenches: np.ndarray
    name: str = "task"
    f_max: float = 1.0
    meta: dict = field(default_factory=dict)
    kind: str = "total"

    per_structure: ClassVar[bool] = False
    """False: one wrench set for every structure (plus its weight for ``external``), so a
    decision on it can be shared across structures (the interface of every task; True for a
    :class:`~modquad_gym.dynamics.DynamicTask`, whose wrenches are each structure's own)."""

    policy_tier: ClassVar[str | None] = None
    """The benchmark tier whose shipped model the learned solvers use on the task (None: the
    default model)."""

    def __post_init__(self) -> None:
        arr = check_wrench_array(self.wrenches)
        arr.setflags(write=False)
        object.__setattr__(self, "wrenches", arr)
        object.__setattr__(self, "f_max", check_f_max(self.f_max))
        check_task_name(self.name)
        if not isinstance(self.meta, dict):
            raise ValueError(f"meta must be a dict, got {type(self.meta).__name__}")
        object.__setattr__(self, "meta", dict(self.meta))
        object.__setattr__(self, "kind", check_kind(self.kind))

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickling (e.g. into vectorised-env workers) keeps the wrenches read-only."""
        object.__setattr__(self, "kind", "total")  # pickles from before kinds existed
        for key, value in state.items():
            object.__setattr__(self, key, value)
        self.wrenches.setflags(write=False)

    # --- identity -------------------------------------------------------------------------
    @property
    def n_wrenches(self) -> int:
        return self.wrenches.shape[0]

    def __len__(self) -> int:
        return self.n_wrenches

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, TaskRequirement):
            return NotImplemented
        return (
            self.name == other.name
            and self.f_max == other.f_max
            and self.kind == other.kind
            and np.array_equal(self.wrenches, other.wrenches)
        )

    def __hash__(self) -> int:
        return hash((self.name, self.f_max, self.kind, self.wrenches.tobytes()))

    def __repr__(self) -> str:
        kind = "" if self.kind == DEFAULT_KIND else f", kind={self.kind!r}"
        return (
            f"TaskRequirement(name={self.name!r}, n_wrenches={self.n_wrenches}, "
            f"f_max={self.f_max:g}{kind})"
        )

    @cached_property
    def wrench_model(self) -> LinearWrenches:
        """The rotor wrenches as a model linear in the structure's mass (the interface every
        task shares with :class:`~modquad_gym.dynamics.DynamicTask`): the wrenches, plus the
        weight for an ``external`` task."""
        return static_model(self.wrenches, self.kind)

    @property
    def decision_model(self) -> LinearWrenches:
        """The wrench model a search decides (:attr:`wrench_model`; a dynamic task's drops its
        repeated samples)."""
        return self.wrench_model

    @property
    def normalised_units(self) -> bool:
        """True for the paper's normalised units (kind ``total``, f_max = 1): forces in units
        of f_max; SI (N, N m) otherwise."""
        return self.kind == DEFAULT_KIND and self.f_max == 1.0

    def describe(self) -> str:
        """``"<t> wrenches"``, with the kind in parentheses unless ``total``."""
        return f"{self.n_wrenches} wrenches{kind_note(self.kind)}"

    def relabelled(self, name: str, meta: dict) -> TaskRequirement:
        """The same task under another name and meta."""
        return dataclasses.replace(self, name=name, meta=meta)

    def with_kind(self, kind: str | None) -> TaskRequirement:
        """The same wrenches of another kind (None: this task; ValueError for an unknown
        kind)."""
        return self if kind is None else dataclasses.replace(self, kind=check_kind(kind))

    def with_f_max(self, f_max: float | None) -> TaskRequirement:
        """The same task with another thrust limit (None: this task)."""
        return self if f_max is None else dataclasses.replace(self, f_max=check_f_max(f_max))

    def check_liftable(self, modules: Any) -> int:
        """The fewest modules the task needs by its weight alone (the interface of
        :func:`~modquad_gym.dynamics.check_liftable`): 1, a static task's weight is decided
        with the rest."""
        return 1

    def flight_seconds(self, hover_seconds: float) -> float:
        """How long one flight of the task lasts: a static task is held for ``hover_seconds``
        (a dynamic task's trajectory sets its own)."""
        return float(hover_seconds)

    def rotor_wrenches(self, structure: Any = 0.0) -> np.ndarray:
        """(t, 6) what the rotors of ``structure`` (a Structure, or its mass in kg) must
        produce: the wrenches themselves for a ``total`` task, plus the weight for an
        ``external`` one (the same question a DynamicTask answers)."""
        mass = getattr(structure, "mass", structure)
        return rotor_wrenches(self.wrenches, self.kind, float(mass))

    # --- dicts ----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """``{"name", "f_max", "wrenches"}`` (plus ``"kind"`` when not ``total`` and ``"meta"``
        when not empty), JSON-ready."""
        out: dict[str, Any] = {"name": self.name, "f_max": self.f_max, **kind_entry(self.kind)}
        out["wrenches"] = self.wrenches.tolist()
        if self.meta:
            out["meta"] = jsonable(self.meta)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], default_name: str = "task") -> TaskRequirement:
        """Build from a dict as written by :meth:`to_dict`. Only ``"wrenches"`` is required; a
        key other than those of :data:`~modquad_gym.tasks.files.TASK_KEYS` is refused (free-form
        extras go into ``"meta"``). Raises ValueError naming the key or the 1-based row."""
        if task_format(data) != "wrenches":
            raise ValueError("a task with a trajectory is dynamic: read it with tasks.load_task")
        wrenches = rows_to_array(data["wrenches"])
        name = check_task_name(data.get("name", default_name), "'name'")
        f_max = check_f_max(data.get("f_max", 1.0))
        kind = check_kind(data.get("kind", "total"), "'kind'")
        meta = check_meta(data.get("meta", {}))
        return cls(wrenches, name=name, f_max=f_max, meta=meta, kind=kind)

    # --- files ----------------------------------------------------------------------------
    @classmethod
    def load(cls, path: PathLike, csv_header: str = "auto") -> TaskRequirement:
        """Read a ``.json``, ``.csv`` or ``.npy`` task file (formats in the module docstring;
        ``csv_header`` as in :data:`CSV_HEADER_MODES`, only ``"auto"`` for a file that is not a
        CSV file); ``example:NAME`` reads a shipped example (:mod:`modquad_gym.tasks.examples`).

        Raises:
            ValueError: naming ``path`` or ``csv_header`` when it is not one.
            FileNotFoundError: naming the path, when there is no such file.
            TaskFileError: naming the file (and 1-based row) for anything wrong in it.
        """
        check_path(path)
        path = resolve_task_path(path)  # "example:NAME" names a shipped example
        check_csv_header(csv_header, path)
        suffix = path.suffix.lower()
        if suffix not in SUFFIXES:
            raise TaskFileError(
                f"{path}: unknown task file type {path.suffix!r}; use one of {', '.join(SUFFIXES)}"
            )
        if not path.exists():
            raise FileNotFoundError(f"task file not found: {path}")
        if not path.is_file():
            raise TaskFileError(f"{path}: not a regular file")
        try:
            if suffix == ".json":
                return cls.from_dict(read_json(path), default_name=path.stem)
            if suffix == ".csv":
                wrenches, fields = read_csv(path, csv_header)
                return cls(wrenches, **{"name": path.stem, **fields})
            return cls(read_npy(path), name=path.stem)
        except TaskFileError:
            raise
        except ValueError as exc:
            raise TaskFileError(f"{path}: {exc}") from None

    def save(self, path: PathLike, force: bool = False, *, what: str = "path") -> Path:
        """Write the task as ``.json`` (name, f_max, kind, wrenches, meta), ``.csv`` (header and
        ``# name`` / ``# f_max`` / ``# kind`` / ``# meta`` comments) or ``.npy`` (wrenches only;
        needs f_max == 1 and kind ``total``, since the format cannot hold them; the name read
        back is the file's stem, meta is not kept). :meth:`load` reads a ``.json`` or ``.csv``
        back identically (name, f_max, kind, meta and the exact floats: shortest round-trip
        repr). An existing file is replaced only with ``force=True`` (as
        :func:`~modquad_gym.sim.export.save_structure`); a folder, a device or an unwritable
        place is refused. ``meta`` must be JSON data: a ValueError names what in it is not (a
        NaN, an object). Every error comes before the file is touched. ``what`` names ``path``
        in the refusal of an existing file: a command's option (``--out``) gets the advice
        ``--force`` (:func:`~modquad_gym.core.outputs.check_output_file`). Returns the path."""
        check_path(path)
        force = check_flag(force, "force")
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in SUFFIXES:
            raise ValueError(
                f"{path}: unknown task file type {path.suffix!r}; use one of {', '.join(SUFFIXES)}"
            )
        text = ""  # .npy: written from the array
        if suffix == ".json":
            text = task_json(self.to_dict()) + "\n"
        elif suffix == ".csv":
            meta = jsonable(self.meta)
            text = csv_text(self.wrenches, self.name, self.f_max, self.kind, meta)
        elif self.f_max != 1.0 or self.kind != "total":
            what = f"f_max={self.f_max:g}" if self.f_max != 1.0 else f"kind={self.kind}"
            raise ValueError(f"{path}: .npy holds only the wrenches, not {what}; save as .json")
        path = check_output_file(path, force=force, what=what)
        if suffix == ".npy":
            data = np.asarray(self.wrenches, dtype=float)
            atomic_write(path, lambda tmp: _save_npy(tmp, data))
        else:
            write_text(path, text)
        return path


def _save_npy(tmp: Path, data: np.ndarray) -> None:
    with tmp.open("wb") as fh:  # a file object: np.save would add ".npy" to a path
        np.save(fh, data)
