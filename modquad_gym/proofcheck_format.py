"""The certificate format of :mod:`modquad_gym.proofcheck` (``docs/certificates.md``): a file read
and every field checked for its JSON type and shape before any proof (numpy and the standard
library only; the checker's second file: copy all three).

Nothing is converted: ``true`` is no number, ``1.0`` no index, ``"1"`` no number; an unknown or
missing key is refused. A :class:`CertificateFormatError` names the first malformed field
(``answer.cells: must be ...``) and what it holds.
"""

from __future__ import annotations

import gzip
import json
import math
import os
import stat
import zlib

import numpy as np

FORMAT, VERSION = "modquad-certificate", 1
TYPE_SHAPES = {"side": (), "c_tau": (), "mass": (), "inertia": (3, 3), "positions": ("r", 3),
               "directions": ("r", 3), "spins": ("r",)}  # fmt: skip
"""The numbers of a module type and their shapes (r: its rotors)."""
MAX_ROTORS = 16
"""Most rotors of a module type (a quad- to octorotor module, with room): the checker's work
and memory grow with them."""
MAX_TEXT = 64 << 20
"""Most bytes of JSON a certificate holds (one of 15 modules of one type, proved structure by
structure, takes about 40 MiB: 0.76 MiB up to 11); a small gzip file must not inflate into
all memory (reading takes about 17 times the JSON's bytes)."""
MAX_LENGTH = 10.0
"""Most metres of a module's side, rotor positions and drag ratio: the checker's tolerances
cover the round-off of torque arms up to there (a rotor at 100 km along its own thrust axis has
a torque arm of round-off alone; a module is well under a metre)."""
UNIT_TOL = 1e-12
"""How far a thrust direction's length may be from 1: the writer's are unit to round-off, and
the columns' formula takes them as unit (a direction of length 0.5 is refused, not rescaled)."""
TASK_KINDS = ("total", "external", "dynamic")
"""What a task's wrenches are: the rotors' total (base alone), the external wrench (the
structure's weight added: per_mass too) or the Newton-Euler wrench of a motion (every term)."""


class CertificateFormatError(ValueError):
    """The file is not a certificate of this format (a malformed field, named)."""


def load(path: str) -> dict:
    """The certificate in ``path`` (UTF-8 JSON, a byte-order mark allowed; gzip-compressed when
    the name ends in ``.gz``), read only up to :data:`MAX_TEXT` bytes of JSON (a file that
    inflates beyond is refused). A path that is not a regular file (a pipe, a device, a
    folder) is refused before anything is read: opened without blocking, then checked."""
    if isinstance(path, str) and not path:  # open("") would say "No such file or directory: ''"
        raise CertificateFormatError("an empty path: give the certificate file")
    try:
        with _regular_file(path) as raw:
            fh = gzip.GzipFile(fileobj=raw, mode="rb") if str(path).endswith(".gz") else raw
            text = fh.read(MAX_TEXT + 1)
        if len(text) > MAX_TEXT:
            raise CertificateFormatError(f"{path}: more than {MAX_TEXT >> 20} MiB of JSON")
        return json.loads(text.decode("utf-8-sig"), object_pairs_hook=_unique_keys)
    except CertificateFormatError:
        raise
    except RecursionError:
        raise CertificateFormatError(f"{path}: JSON nested too deeply") from None
    except (OSError, EOFError, ValueError, zlib.error) as e:  # ValueError: not UTF-8 or JSON
        raise CertificateFormatError(f"{path}: cannot read a JSON certificate ({e})") from None


def _regular_file(path: str):
    """``path`` open for reading in binary, or a CertificateFormatError when it is not a
    regular file (a pipe would block the read forever, a device never end)."""
    nonblocking = getattr(os, "O_NONBLOCK", 0)  # a pipe opens at once (POSIX)
    fd = os.open(path, os.O_RDONLY | nonblocking)
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise CertificateFormatError(f"{path}: not a regular file")
    if nonblocking:
        os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


def _unique_keys(pairs: list) -> dict:
    keys = [k for k, _ in pairs]
    if len(set(keys)) < len(keys):
        raise ValueError(f"the key {next(k for k in keys if keys.count(k) > 1)!r} is given twice")
    return dict(pairs)


def fields(value, what: str, keys: str, optional: str = "") -> dict:
    """``value``, a JSON object with each of ``keys``, maybe some of ``optional``, no other."""
    known = keys.split() + optional.split()
    if type(value) is not dict:
        raise CertificateFormatError(f"{what}: must be an object, not {_shown(value)}")
    for k in value:
        if k not in known:
            raise CertificateFormatError(f"{what}: unknown key {k!r} (keys: {', '.join(known)})")
    for k in keys.split():
        if k not in value:
            raise CertificateFormatError(f"{what}: the key {k!r} is missing")
    return value


def array(value, what: str, dims: tuple = (), integer=False, finite=True) -> np.ndarray:
    """``value`` as an array: lists nested one level per entry of ``dims`` (a length, or a
    letter: any length, the same at that level) of JSON numbers, 64-bit integers if ``integer``,
    finite if ``finite``."""
    kind = "integers" if integer else "finite numbers" if finite else "numbers"
    if not dims:
        form = "an integer" if integer else f"a {kind[:-1]}"
    elif len(dims) == 1 and type(dims[0]) is str:
        form = f"a list of {kind}"
    else:
        form = f"a list ({' x '.join(map(str, dims))}) of {kind}"
    rows, shape, large = [value], [], ""
    for size in dims:
        n = size if type(size) is int else len(rows[0]) if rows and type(rows[0]) is list else 0
        bad = [r for r in rows if type(r) is not list or len(r) != n]
        if bad:
            break
        shape.append(n)
        rows = [x for r in rows for x in r]
    else:
        bad = [x for x in rows if not _number(x, integer, finite)]
        large = " (too large)" if bad and type(bad[0]) is int else ""
    if bad:
        found = f", not {_shown(value)}" if bad[0] is value else f"; it holds {_shown(bad[0])}"
        raise CertificateFormatError(f"{what}: must be {form}{found}{large}")
    return np.array(rows, dtype=np.int64 if integer else float).reshape(shape)


def _number(x, integer: bool, finite: bool) -> bool:
    if type(x) is int:  # a bool is not: type(True) is bool
        return -(2**63) <= x < 2**63 if integer else abs(x) < 1e308
    return isinstance(x, float) and not integer and (math.isfinite(x) or not finite)


def _shown(x) -> str:
    """A JSON value as a message shows it: a list by its length, a string cut short."""
    if type(x) in (list, dict):
        return f"a list of length {len(x)}" if type(x) is list else "an object"
    return json.dumps(x)[:40]


def _text(value, what: str) -> None:
    if type(value) is not str and value is not None:
        raise CertificateFormatError(f"{what}: must be a string or null, not {_shown(value)}")


def module_types(types) -> dict:
    """The fields of :data:`TYPE_SHAPES`, each stacked over the types; every type has as many
    rotors as the first, at least one."""
    if type(types) is not list or not types:
        raise CertificateFormatError(f"types: must be a non-empty list, not {_shown(types)}")
    rows = []
    for i, t in enumerate(types):
        fields(t, f"types[{i}]", "name " + " ".join(TYPE_SHAPES))
        _text(t["name"], f"types[{i}].name")
        rows.append({k: array(t[k], f"types[{i}].{k}", s) for k, s in TYPE_SHAPES.items()})
        r = len(rows[0]["spins"])
        same = all(len(rows[i][k]) == r for k in ("positions", "directions", "spins"))
        if not 1 <= r <= MAX_ROTORS or not same:
            raise CertificateFormatError(
                f"types[{i}]: positions, directions, spins: one row per rotor, as many rotors "
                f"as types[0] ({r}), 1 to {MAX_ROTORS}"
            )
        _physical(rows[i], rows[0]["side"], f"types[{i}]")
    return {k: np.stack([a[k] for a in rows]) for k in TYPE_SHAPES}


def _physical(t: dict, side: float, what: str) -> None:
    """A module type's numbers say one physical thing: a positive mass and side (the first
    type's), lengths of at most :data:`MAX_LENGTH`, spins of +-1, unit thrust directions,
    a symmetric inertia matrix that is positive semi-definite (the checker reads its upper
    triangle)."""
    J, most = t["inertia"], f"must be at most {MAX_LENGTH:g} m"
    wrong = [
        (not t["mass"] > 0, "mass", "must be positive", t["mass"]),
        (not t["side"] > 0, "side", "must be positive", t["side"]),
        (not t["side"] <= MAX_LENGTH, "side", most, t["side"]),
        (not abs(t["c_tau"]) <= MAX_LENGTH, "c_tau", f"{most} in magnitude", t["c_tau"]),
        (not np.all(np.abs(t["positions"]) <= MAX_LENGTH), "positions", f"{most} in each axis",
         t["positions"]),
        (t["side"] != side, "side", f"must be the first type's ({side!r})", t["side"]),
        (not np.all(np.abs(t["spins"]) == 1), "spins", "must each be 1 or -1", t["spins"]),
        (np.any(J != J.T), "inertia", "must be symmetric", J),
        (np.linalg.eigvalsh(J).min() < -1e-12 * np.abs(J).max(), "inertia",
         "must be positive semi-definite", J),
    ]  # fmt: skip
    for bad, field, rule, value in wrong:
        if bad:
            shown = json.dumps(np.asarray(value).tolist())[:60]
            raise CertificateFormatError(f"{what}.{field}: {rule}, not {shown}")
    with np.errstate(over="ignore"):  # a huge entry: an infinite length, refused
        length = np.linalg.norm(t["directions"], axis=1)
    off = np.flatnonzero(~(np.abs(length - 1.0) <= UNIT_TOL))  # NaN refused too
    if len(off):
        k = int(off[0])
        raise CertificateFormatError(
            f"{what}.directions[{k}]: rotor {k + 1}'s thrust direction must be a unit vector "
            f"(length within {UNIT_TOL:g} of 1), not of length {length[k]:.17g}"
        )


def task_model(task) -> tuple:
    """(base (t, 6), per_mass (t, 6), per_inertia (t, 6, 6)) of the task; null: zeros."""
    fields(task, "task", "name kind base per_mass per_inertia")
    _text(task["name"], "task.name")
    if task["kind"] not in TASK_KINDS:
        kinds = ", ".join(map(json.dumps, TASK_KINDS))
        raise CertificateFormatError(f"task.kind: must be {kinds}, not {_shown(task['kind'])}")
    base = array(task["base"], "task.base", ("t", 6))
    if not len(base):
        raise CertificateFormatError("task.base: must hold at least one wrench")
    t, pm, pi = len(base), task["per_mass"], task["per_inertia"]
    pm = np.zeros((t, 6)) if pm is None else array(pm, "task.per_mass", (t, 6))
    pi = np.zeros((t, 6, 6)) if pi is None else array(pi, "task.per_inertia", (t, 6, 6))
    for field, terms, needless in (("per_mass", pm, "total"), ("per_inertia", pi, "external")):
        if np.any(terms) and TASK_KINDS.index(task["kind"]) <= TASK_KINDS.index(needless):
            raise CertificateFormatError(
                f"task.{field}: must be null or zero for a {task['kind']} task (its kind has "
                "no such term)"
            )
    g = pm[0, 2]
    if task["kind"] == "external" and not (g > 0 and np.all(pm == [0, 0, g, 0, 0, 0])):
        raise CertificateFormatError(
            "task.per_mass: an external task's is the weight, one (0, 0, g, 0, 0, 0) with g > 0 "
            f"for every wrench, not {json.dumps(pm[0].tolist())[:60]}"
        )
    return base, pm, pi


def answer(value) -> tuple:
    """(cells (n, 2), types (n,), allocations (F, t, m)) of the answer; a thrust may be NaN
    here (the proof refuses it, as it refuses any other thrust that does not work)."""
    fields(value, "answer", "cells types allocations")
    cells = array(value["cells"], "answer.cells", ("n", 2), integer=True)
    types = array(value["types"], "answer.types", ("n",), integer=True)
    thrusts = array(value["allocations"], "answer.allocations", ("F", "t", "m"), finite=False)
    return cells, types, thrusts


def levels(entries, fault) -> dict:
    """{n: the proof of level n}: {"bound": (direction, wrench)}, or arrays of one entry per
    structure: {"direction", "wrench"} and, with a fault, "failure"."""
    if type(entries) is not list:
        raise CertificateFormatError(f"levels: must be a list, not {_shown(entries)}")
    out = {}
    for k, e in enumerate(entries):
        bound = type(e) is dict and "bound" in e
        proof = ("bound",) if bound else ("direction", "wrench") + ("failure",) * bool(fault)
        fields(e, f"levels[{k}]", " ".join(("n",) + proof))
        n = int(array(e["n"], f"levels[{k}].n", integer=True))
        if n in out:
            raise CertificateFormatError(f"levels[{k}].n: a second proof of level {n}")
        if bound:
            b = fields(e["bound"], f"level {n}: bound", "direction wrench")
            p, i = (
                int(array(b[x], f"level {n}: bound.{x}", integer=True))
                for x in ("direction", "wrench")
            )
            out[n] = {"bound": (p, i)}
        else:
            out[n] = {x: array(e[x], f"level {n}: {x}", ("s",), integer=True) for x in proof}
    return out


def parse(cert) -> dict:
    """The certificate's fields as numbers and arrays, every one checked here, before any
    proof: f_max, fault, task (:func:`task_model`), minimum, top (the largest level proved),
    answer (:func:`answer`, or None), directions (P, 6), levels (:func:`levels`)."""
    if type(cert) is not dict or cert.get("format") != FORMAT:
        raise CertificateFormatError(f'not a {FORMAT}: a JSON object whose "format" is "{FORMAT}"')
    if "version" not in cert:  # checked before the other keys: another version has others
        raise CertificateFormatError("certificate: the key 'version' is missing")
    version = cert["version"]
    if type(version) is not int or version != VERSION:
        raise CertificateFormatError(f"version: must be {VERSION}, not {_shown(version)}")
    keys = "format version f_max fault types task minimum directions levels"
    c = fields(cert, "certificate", keys, "n_max answer producer")
    if c["fault"] not in (None, "rotor", "module"):
        raise CertificateFormatError(
            f'fault: must be null, "rotor" or "module", not {_shown(c["fault"])}'
        )
    f_max = float(array(c["f_max"], "f_max"))
    if not f_max > 0:
        raise CertificateFormatError(f"f_max: must be positive, not {_shown(c['f_max'])}")
    minimum = None if c["minimum"] is None else int(array(c["minimum"], "minimum", integer=True))
    if (minimum is None) != ("n_max" in c) or (minimum is None) == ("answer" in c):
        raise CertificateFormatError("minimum: a number with an answer, or null with n_max")
    top = int(array(c["n_max"], "n_max", integer=True)) if minimum is None else minimum - 1
    if top < 1 and minimum is None:  # n_max 0 would prove nothing
        raise CertificateFormatError(f"n_max: must be at least 1, not {top}")
    if top < 0:
        raise CertificateFormatError("minimum: must be at least 1")
    if "producer" in c:
        _text(fields(c["producer"], "producer", "method")["method"], "producer.method")
    module_types(c["types"])  # Types (the checker's) builds them again, checked here first
    return {
        "f_max": f_max,
        "fault": c["fault"],
        "task": task_model(c["task"]),
        "minimum": minimum,
        "top": top,
        "answer": None if minimum is None else answer(c["answer"]),
        "directions": array(c["directions"], "directions", ("P", 6)),
        "levels": levels(c["levels"], c["fault"]),
    }
