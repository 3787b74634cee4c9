"""Task requirements (paper Def. 3): the wrenches a structure must be able to exert.

A :class:`TaskRequirement` is a (t, 6) array of wrenches ``[fx, fy, fz, tx, ty, tz]`` in the
structure frame {S} (torques about the COM), with the per-rotor thrust limit ``f_max``, and a
*kind* (:data:`TASK_KINDS`) that says what the wrenches are:

``total`` (the default, the paper's)
    the total wrench the rotors must produce; gravity compensation is folded into ``fz``, the
    same for every structure. Units are those of ``f_max`` (normalised to 1 in the paper).
``external``
    the wrench the structure must apply to the environment or a payload, in {S} at hover
    attitude (level). The rotors must produce it *plus* the structure's own weight:
    ``w + m_total g e_z`` (:func:`rotor_wrenches`; weight acts at the COM, so it adds no
    torque), so the answer depends on the structure's mass and bigger structures must lift
    more. Units are SI: newtons, newton-metres, ``f_max`` in newtons, module masses in kg,
    g = :data:`~modquad_gym.geometry.module.GRAVITY`.

Task files (:mod:`.files`):

``.json``
    ``{"wrenches": [[fx, fy, fz, tx, ty, tz], ...], "f_max": 1.0, "name": "..."}``; only
    ``wrenches`` is required (``name`` defaults to the file stem and is never empty, ``f_max``
    to 1, ``kind`` to ``"total"``, so every file written before kinds existed means what it
    meant). An optional ``meta`` object carries extra information (e.g. a planted structure, a
    known optimum); it must be JSON that can be written back (no ``NaN``, no ``Infinity``).
    Any other key, ``null`` for a key, and a key given twice are refused (:data:`TASK_KEYS`
    lists the known ones). Every number is a JSON number: ``"1"`` and ``true`` are refused.
``.csv``
    Six comma-separated columns, one wrench per line. An optional first line is a header naming
    the columns ``fx, fy, fz, tx, ty, tz`` (in any order: the names are honoured); a first line
    ``0,1,2,3,4,5`` or ``1,2,3,4,5,6`` (column numbers) is refused as ambiguous unless
    ``csv_header`` says how to read it. Blank lines are ignored; lines starting with ``#`` are
    comments, and the comments ``# name: ...``, ``# f_max: ...``, ``# kind: ...`` and
    ``# meta: {...}`` (one line of JSON), each at most once, set those fields (a name in double
    quotes is a JSON string: how :meth:`TaskRequirement.save` writes a name with a newline).
    A near miss is refused, naming the line, never read as free text: a misspelt key
    (``# fmax: 2``, ``# f max: 2``) or a key without its ``:`` (``# f_max = 2``, ``#f_max=2``,
    ``# f_max 2``), so free text must not start with one of these keys. ``csv_header``
    applies to CSV files only (another mode than ``auto`` for a ``.json`` or ``.npy`` file is
    refused).
``.npy``
    A numeric array of shape (t, 6) and nothing after it (``f_max`` = 1, kind ``total``, name =
    file stem).

A bad file raises :class:`TaskFileError` (a ValueError) naming the file and, where it applies,
the 1-based data row (header, blank and comment lines are not counted; the line number is given
too). Files are parsed completely before a task is built: nothing is ever half-loaded.

Seeded task generators share one interface, :class:`TaskGenerator` (``name`` and
``__call__(rng) -> TaskRequirement``): :class:`PaperTasks` (paper Sec. VI, errata 2),
:class:`PlantedTasks` (wrenches inside a hidden structure's zonotope, so the optimum is bounded),
:class:`ScrewdriverTask` (paper Fig. 1), :class:`MixedTasks` and :class:`FixedTasks`.
:func:`make_generator` turns a spec (a name, a file, tasks) into a generator; a *suite* is a JSON
file of several tasks (:func:`load_suite`, :func:`save_suite`).

Example tasks ship with the package: ``example:NAME`` wherever a task file is read
(:mod:`.examples`, :func:`example_names`).

A JSON object with a ``"trajectory"`` is a *dynamic* task (:mod:`modquad_gym.dynamics`): a
motion, an optional payload and exerted wrenches, whose rotor wrenches depend on the structure's
mass and inertia; :func:`load_task` reads either kind of file.

Modules: :mod:`.wrenches` (wrench checks, kinds), :mod:`.files` (reading task files: JSON,
.npy, the known keys), :mod:`.csvfile` (CSV), :mod:`.requirement` (:class:`TaskRequirement`),
:mod:`.loading` (:func:`load_task`),
:mod:`.suites`, :mod:`.generators` (the seeded generators) and :mod:`.specs` (the generators
by name, :func:`make_generator`).
"""

from modquad_gym.tasks.csvfile import CSV_COMMENT_KEYS, CSV_HEADER_MODES
from modquad_gym.tasks.examples import example_names, example_path
from modquad_gym.tasks.files import (
    MAX_FILE_BYTES,
    SUFFIXES,
    SUITE_KEYS,
    TASK_KEYS,
    PathLike,
    TaskFileError,
    task_files,
)
from modquad_gym.tasks.generators import (
    FZ_READINGS,
    Count,
    FixedTasks,
    MixedTasks,
    PaperTasks,
    PlantedMixedTasks,
    PlantedTasks,
    ScrewdriverTask,
    TaskGenerator,
    planted_structure,
    random_cells,
)
from modquad_gym.tasks.loading import as_task, is_dynamic, load_task
from modquad_gym.tasks.requirement import TaskRequirement
from modquad_gym.tasks.specs import (
    GENERATE_KINDS,
    GENERATORS,
    NAMED_GENERATORS,
    generated_task,
    make_generator,
)
from modquad_gym.tasks.suites import load_suite, save_suite
from modquad_gym.tasks.wrenches import COLUMNS, MAX_WRENCHES, TASK_KINDS, check_kind, rotor_wrenches

__all__ = [
    "as_task",
    "example_names",
    "example_path",
    "COLUMNS",
    "CSV_COMMENT_KEYS",
    "CSV_HEADER_MODES",
    "FZ_READINGS",
    "GENERATE_KINDS",
    "GENERATORS",
    "MAX_FILE_BYTES",
    "MAX_WRENCHES",
    "NAMED_GENERATORS",
    "SUFFIXES",
    "SUITE_KEYS",
    "TASK_KEYS",
    "TASK_KINDS",
    "Count",
    "FixedTasks",
    "MixedTasks",
    "PaperTasks",
    "PathLike",
    "PlantedMixedTasks",
    "PlantedTasks",
    "ScrewdriverTask",
    "TaskFileError",
    "TaskGenerator",
    "TaskRequirement",
    "check_kind",
    "is_dynamic",
    "generated_task",
    "load_task",
    "load_suite",
    "make_generator",
    "planted_structure",
    "random_cells",
    "rotor_wrenches",
    "save_suite",
    "task_files",
]
