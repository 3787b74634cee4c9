"""Malformed certificates (findings 3, 4, 8, 9, 10 of the input review): every one is refused by
both doors, ``modquad check`` and ``python -m modquad_gym.proofcheck``, with one line that names
the file, the field and what it holds, and exit code 2 (exit 1 is kept for a well-formed
certificate whose claim fails). Unknown keys are refused at every level of the format and no
value is converted: true is no number, 1.0 no index, "1" no number."""

from __future__ import annotations

import copy
import gzip
import json

import pytest

from modquad_gym import proofcheck as pc
from modquad_gym.cli import main


@pytest.fixture(scope="module")
def certs(tmp_path_factory):
    """The screwdriver's certificates as written by ``modquad solve --certificate``: intact
    (minimum 3: level 1 by a bound, level 2 structure by structure) and rotor-fault tolerant."""
    folder = tmp_path_factory.mktemp("certs")
    out = {}
    for name, extra in (("intact", []), ("rotor", ["--fault", "rotor"])):
        path = folder / f"{name}.json"
        argv = ["solve", "--task", "example:screwdriver", "--method", "exhaustive", *extra]
        assert main([*argv, "--certificate", str(path)]) == 0
        out[name] = json.loads(path.read_text())
    assert [sorted(e) for e in out["intact"]["levels"]] == [
        ["bound", "n"],
        ["direction", "n", "wrench"],
    ]
    return out


def doors(path, capsys) -> list[tuple[int, str, str]]:
    """(exit code, stdout, stderr) of ``modquad check PATH`` and of the checker's own door."""
    out = []
    for door in (lambda: main(["check", str(path)]), lambda: pc.main([str(path)])):
        code = door()
        captured = capsys.readouterr()
        out.append((code, captured.out, captured.err))
    return out


def refused(path, capsys, words: str) -> None:
    """Both doors exit 2 with one line ``[modquad: ]error: PATH: ...words...``."""
    for (code, out, err), prefix in zip(doors(path, capsys), ("modquad: error: ", "error: ")):
        assert code == 2, (code, out, err)
        assert err.startswith(f"{prefix}{path}: "), err
        assert words in err and err.count("\n") == 1 and "Traceback" not in err, err
        assert "valid" not in out


def test_the_written_certificates_are_valid_by_both_doors(certs, tmp_path, capsys):
    for name, cert in certs.items():
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps(cert))
        for code, out, _ in doors(path, capsys):
            assert code == 0 and out.startswith("valid: the minimum is"), (name, out)


def _flipped_gzip(text: str) -> bytes:
    data = bytearray(gzip.compress(text.encode(), mtime=0))
    for i in range(20, 60):  # the header stays valid, the deflate stream does not
        data[i] ^= 0xFF
    return bytes(data)


UNREADABLE = {
    "corrupt gzip": (".json.gz", _flipped_gzip, "cannot read a JSON certificate"),
    "truncated gzip": (".json.gz", lambda t: gzip.compress(t.encode())[:200], "cannot read"),
    "deeply nested": (".json", lambda t: b"[" * 200_000 + b"]" * 200_000, "nested too deeply"),
    "a key twice": (
        ".json",
        lambda t: t[:-1].encode() + b', "f_max": 2}',
        "'f_max' is given twice",
    ),
    "not UTF-8": (".json", lambda t: b"\xff\xfe" + t.encode(), "cannot read a JSON certificate"),
    "a 5000-digit number": (
        ".json",
        lambda t: t.replace('"f_max": 1.0', '"f_max": ' + "1" * 5000).encode(),
        "cannot read a JSON certificate",
    ),  # fmt: skip
    "empty": (".json", lambda t: b"", "cannot read a JSON certificate"),
}


@pytest.mark.parametrize("case", UNREADABLE)
def test_a_file_that_is_not_json_is_one_line_exit_2(case, certs, tmp_path, capsys):
    suffix, make, words = UNREADABLE[case]
    text = json.dumps(certs["intact"])
    assert '"f_max": 1.0' in text
    path = tmp_path / f"cert{suffix}"
    path.write_bytes(make(text))
    refused(path, capsys, words)


def _at(cert, keys):
    for k in keys:
        cert = cert[k]
    return cert


UNKNOWN_KEYS = {  # where the key is added: the name the message gives that place
    (): "certificate",
    ("task",): "task",
    ("types", 0): "types[0]",
    ("answer",): "answer",
    ("levels", 0): "levels[0]",
    ("levels", 0, "bound"): "level 1: bound",
    ("levels", 1): "levels[1]",
    ("producer",): "producer",
}


@pytest.mark.parametrize("keys", UNKNOWN_KEYS, ids=list(UNKNOWN_KEYS.values()))
def test_an_unknown_key_is_refused_at_every_level(keys, certs, tmp_path, capsys):
    cert = copy.deepcopy(certs["intact"])
    place = _at(cert, keys)
    known = ", ".join(place)
    place["extra"] = 1
    with pytest.raises(pc.CertificateFormatError) as info:
        pc.check(cert)
    assert str(info.value).startswith(f"{UNKNOWN_KEYS[keys]}: unknown key 'extra' (keys: ")
    assert all(k in str(info.value) for k in known.split(", "))
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert))
    refused(path, capsys, f"{UNKNOWN_KEYS[keys]}: unknown key 'extra'")


def _set(keys, value):
    def change(cert):
        _at(cert, keys[:-1])[keys[-1]] = value

    return change


def _other_rotors(cert):
    cert["types"].append(copy.deepcopy(cert["types"][0]))
    cert["types"][1]["spins"] = [1.0, -1.0]


MALFORMED = {  # name: (change, the message after the file name)
    "version true": (_set(["version"], True), "version: must be 1, not true"),
    "version 1.0": (_set(["version"], 1.0), "version: must be 1, not 1.0"),
    "no version": (lambda c: c.pop("version"), "certificate: the key 'version' is missing"),
    "f_max a string": (_set(["f_max"], "1"), 'f_max: must be a finite number, not "1"'),
    "f_max true": (_set(["f_max"], True), "f_max: must be a finite number, not true"),
    "f_max infinite": (_set(["f_max"], float("inf")), "f_max: must be a finite number, not Inf"),
    "f_max zero": (_set(["f_max"], 0), "f_max: must be positive, not 0"),
    "minimum true": (_set(["minimum"], True), "minimum: must be an integer, not true"),
    "minimum 3.0": (_set(["minimum"], 3.0), "minimum: must be an integer, not 3.0"),
    "minimum of 71 bits": (
        _set(["minimum"], 2**70),
        f"minimum: must be an integer, not {2**70} (too large)",
    ),  # fmt: skip
    "minimum without answer": (
        _set(["minimum"], None),
        "minimum: a number with an answer, or null with n_max",
    ),  # fmt: skip
    "bound direction 0.9": (
        _set(["levels", 0, "bound", "direction"], 0.9),
        "level 1: bound.direction: must be an integer, not 0.9",
    ),
    "bound direction a string": (
        _set(["levels", 0, "bound", "direction"], "x"),
        'level 1: bound.direction: must be an integer, not "x"',
    ),
    "bound direction infinite": (
        _set(["levels", 0, "bound", "direction"], float("inf")),
        "level 1: bound.direction: must be an integer, not Infinity",
    ),
    "bound a number": (_set(["levels", 0, "bound"], 5), "level 1: bound: must be an object, not 5"),
    "structure direction of 71 bits": (
        _set(["levels", 1, "direction"], [0, 2**70]),
        f"level 2: direction: must be a list of integers; it holds {2**70} (too large)",
    ),  # fmt: skip
    "structure wrench true": (
        _set(["levels", 1, "wrench", 0], True),
        "level 2: wrench: must be a list of integers; it holds true",
    ),
    "level n 2.0": (_set(["levels", 1, "n"], 2.0), "levels[1].n: must be an integer, not 2.0"),
    "level twice": (
        _set(["levels", 1], {"n": 1, "bound": {"direction": 0, "wrench": 0}}),
        "levels[1].n: a second proof of level 1",
    ),
    "levels null": (_set(["levels"], None), "levels: must be a list, not null"),
    "a level not an object": (
        _set(["levels", 1], [2]),
        "levels[1]: must be an object, not a list of length 1",
    ),  # fmt: skip
    "cells of three": (
        _set(["answer", "cells", 0], [0, 0, 0]),
        "answer.cells: must be a list (n x 2) of integers; it holds a list of length 3",
    ),  # fmt: skip
    "cell 0.5": (
        _set(["answer", "cells", 2, 1], 0.5),
        "answer.cells: must be a list (n x 2) of integers; it holds 0.5",
    ),  # fmt: skip
    "type index a string": (
        _set(["answer", "types", 0], "0"),
        'answer.types: must be a list of integers; it holds "0"',
    ),
    "allocations ragged": (
        lambda c: c["answer"]["allocations"][0][1].pop(),
        "answer.allocations: must be a list (F x t x m) of numbers; it holds a list of length 11",
    ),  # fmt: skip
    "directions of five": (
        lambda c: c.__setitem__("directions", c["directions"][0][:5]),
        "directions: must be a list (P x 6) of finite numbers; it holds",
    ),
    "direction NaN": (
        _set(["directions", 0, 0], float("nan")),
        "directions: must be a list (P x 6) of finite numbers; it holds NaN",
    ),
    "types of unequal rotors": (
        _other_rotors,
        "types[1]: positions, directions, spins: one row per rotor, as many rotors as types[0] (4)",
    ),  # fmt: skip
    "spins a number": (
        _set(["types", 0, "spins"], 5),
        "types[0].spins: must be a list of finite numbers, not 5",
    ),
    "positions ragged": (
        _set(["types", 0, "positions", 1], [-0.1, 0.1]),
        "types[0].positions: must be a list (r x 3) of finite numbers; it holds a list of length 2",
    ),  # fmt: skip
    "type name a number": (
        _set(["types", 0, "name"], 5),
        "types[0].name: must be a string or null, not 5",
    ),
    "per_mass a string": (
        _set(["task", "per_mass"], "abc"),
        'task.per_mass: must be a list (2 x 6) of finite numbers, not "abc"',
    ),
    "no wrench": (_set(["task", "base"], []), "task.base: must hold at least one wrench"),
    "fault a list": (
        _set(["fault"], ["rotor"]),
        'fault: must be null, "rotor" or "module", not a list of length 1',
    ),
    "no directions": (
        lambda c: c.pop("directions"),
        "certificate: the key 'directions' is missing",
    ),  # fmt: skip
    "an empty object": (lambda c: c.clear(), "not a modquad-certificate"),
}


@pytest.mark.parametrize("case", MALFORMED)
def test_a_malformed_field_is_named_and_never_converted(case, certs, tmp_path, capsys):
    change, words = MALFORMED[case]
    cert = copy.deepcopy(certs["intact"])
    change(cert)
    with pytest.raises(pc.CertificateFormatError) as info:
        pc.check(cert)
    assert str(info.value).startswith(words), str(info.value)
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert))
    refused(path, capsys, words)


def test_failures_belong_to_a_fault_and_a_fault_needs_them(certs):
    cert = copy.deepcopy(certs["rotor"])
    cert["levels"][1].pop("failure")
    with pytest.raises(pc.CertificateFormatError, match=r"^levels\[1\]: the key 'failure' is"):
        pc.check(cert)
    cert = copy.deepcopy(certs["intact"])
    cert["levels"][1]["failure"] = [-1, -1]
    with pytest.raises(pc.CertificateFormatError, match=r"^levels\[1\]: unknown key 'failure'"):
        pc.check(cert)


def test_a_well_formed_claim_that_fails_is_still_exit_1(certs, tmp_path, capsys):
    """The format checks come first; a well-formed certificate with a wrong claim is invalid."""
    cert = copy.deepcopy(certs["intact"])
    cert["answer"]["allocations"][0][0][0] += 0.01
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert))
    for code, out, err in doors(path, capsys):
        assert code == 1 and out.startswith("invalid: answer: allocation: wrench 0") and not err
