"""Issue 24, family 2: one strict reading of task files. Unknown keys, misspelt comments, headers
that name other columns, numeric-looking headers and duplicates are refused with a line naming
the file (and line); what ``save`` writes, ``load`` reads back identically."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from modquad_gym.tasks import TASK_KEYS, TASK_KINDS, TaskFileError, TaskRequirement, load_suite

ROUND_TRIP = settings(
    max_examples=60,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)


def load(tmp_path, name: str, text: str | bytes, **kw) -> TaskRequirement:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return TaskRequirement.load(path, **kw)


def refused(tmp_path, name: str, text: str, *words: str, **kw) -> str:
    with pytest.raises(TaskFileError) as info:
        load(tmp_path, name, text, **kw)
    message = str(info.value)
    assert name in message and "\n" not in message, message
    for word in words:
        assert word in message, (word, message)
    return message


W = "[[0, 0, 6, 0.1, 0, 0]]"


# --- unknown and duplicate keys ---------------------------------------------------------------
@pytest.mark.parametrize(
    "extra, words",
    [
        ('"fmax": 2.0', ["'fmax'", "did you mean 'f_max'", "meta"]),
        ('"Kind": "external"', ["'Kind'", "did you mean 'kind'"]),
        ('"modules": ["t99"]', ["'modules'", "wrenches, name, f_max, kind, meta"]),
        ('"optimum": 3', ["'optimum'", "meta"]),
    ],
)
def test_unknown_json_keys_are_refused_with_the_known_ones(tmp_path, extra, words):
    refused(tmp_path, "t.json", f'{{"wrenches": {W}, {extra}}}', *words)


def test_duplicate_json_keys_are_refused_at_any_depth(tmp_path):
    refused(tmp_path, "a.json", f'{{"wrenches": {W}, "f_max": 1, "f_max": 3}}', "'f_max'", "twice")
    refused(tmp_path, "b.json", f'{{"wrenches": {W}, "meta": {{"x": 1, "x": 2}}}}', "'x'", "twice")
    suite = f'{{"name": "s", "tasks": [{{"wrenches": {W}}}], "tasks": []}}'
    with pytest.raises(TaskFileError, match="'tasks' is given twice"):
        (tmp_path / "s.json").write_text(suite)
        load_suite(tmp_path / "s.json")


def test_unknown_suite_keys_are_refused(tmp_path):
    path = tmp_path / "s.json"
    path.write_text(f'{{"name": "s", "tasks": [{{"wrenches": {W}}}], "Name": "x"}}')
    with pytest.raises(TaskFileError, match="unknown key 'Name'.*name, tasks"):
        load_suite(path)
    path.write_text(f'{{"tasks": [{{"wrenches": {W}, "optimum": 2}}]}}')
    with pytest.raises(TaskFileError, match="task 1: unknown key 'optimum'"):
        load_suite(path)


def test_the_known_keys_are_one_table():
    assert TASK_KEYS["wrenches"] == ("wrenches", "name", "f_max", "kind", "meta")
    d = TaskRequirement(np.ones((1, 6)), meta={"a": 1}, kind="external").to_dict()
    assert set(d) <= set(TASK_KEYS["wrenches"])


# --- CSV comments ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "comments, words",
    [
        ("# f_max: 1\n# f_max: 3\n", ["line 2", "second '# f_max'", "line 1"]),
        ("# name: a\n# name: b\n", ["second '# name'"]),
        ("# f_max: 1_000\n", ["line 1", "'1_000' is not a number"]),
        ("# f_max: inf\n", ["line 1", "f_max must be finite"]),
        ("# fmax: 2\n", ["line 1", "'fmax'", "did you mean 'f_max'"]),
        ("# Kind: external\n", ["'Kind'", "did you mean 'kind'"]),
        ("# kind: externall\n", ["line 1", "kind comment must be one of"]),
        ("# meta: [1]\n", ["line 1", "JSON object"]),
        ('# meta: {"a": 1, "a": 2}\n', ["line 1", "'a' is given twice"]),
        ("# name:\n", ["line 1", "without a name"]),
    ],
)
def test_bad_csv_comments_are_refused(tmp_path, comments, words):
    refused(tmp_path, "t.csv", comments + "0,0,6,0,0,0\n", *words)


def test_free_text_comments_stay_comments(tmp_path):
    task = load(tmp_path, "t.csv", "# note: measured on the bench\n# f_max: 2\n0,0,6,0,0,0\n")
    assert task.f_max == 2.0 and task.name == "t"


# --- CSV headers -----------------------------------------------------------------------------
def test_a_header_naming_the_columns_is_honoured(tmp_path):
    task = load(tmp_path, "t.csv", "tx,ty,tz,fx,fy,fz\n0.1,0,0,0,0,6\n")
    np.testing.assert_array_equal(task.wrenches, [[0, 0, 6, 0.1, 0, 0]])
    same = load(tmp_path, "u.csv", " FX, Fy ,fz,tx,ty,tz\n0,0,6,0.1,0,0\n", csv_header="yes")
    np.testing.assert_array_equal(same.wrenches, task.wrenches)


@pytest.mark.parametrize(
    "header, mode, words",
    [
        ("a,b,c,d,e,f", "auto", ["line 1", "names 'a'", "fx, fy, fz, tx, ty, tz"]),
        ("fx,fy,fz,tx,ty,fx", "auto", ["line 1", "given twice"]),
        ("fx,fy,fz,tx,ty", "auto", ["line 1", "names"]),
        ("1,2,3,4,5,6", "auto", ["line 1", "column numbers", "--csv-header"]),
        ("0,1,2,3,4,5", "auto", ["line 1", "column numbers"]),
        ("0,0,6,0,0,0", "yes", ["line 1", "is a wrench, not column names"]),
    ],
)
def test_headers_that_name_no_columns_are_refused(tmp_path, header, mode, words):
    refused(tmp_path, "t.csv", f"{header}\n0,0,6,0,0,0\n", *words, csv_header=mode)


def test_column_number_headers_read_as_told(tmp_path):
    text = "1,2,3,4,5,6\n0,0,6,0,0,0\n"
    assert load(tmp_path, "a.csv", text, csv_header="yes").n_wrenches == 1
    assert load(tmp_path, "b.csv", text, csv_header="no").n_wrenches == 2


@pytest.mark.parametrize("sep, word", [(";", "semicolons"), ("\t", "tabs")])
def test_other_separators_are_named(tmp_path, sep, word):
    row = sep.join("006000")
    refused(tmp_path, "t.csv", f"{row}\n{row}\n", "line 1", word)


def test_old_mac_line_ends_read(tmp_path):
    task = load(tmp_path, "t.csv", "fx,fy,fz,tx,ty,tz\r0,0,6,0,0,0\r0,0,5,0,0,0\r")
    assert task.n_wrenches == 2


def test_npy_that_is_text_or_too_large_is_refused_from_its_header(tmp_path):
    refused(tmp_path, "t.npy", "hello\n", "not an .npy file")
    path = tmp_path / "big.npy"
    with path.open("wb") as fh:  # a header promising 2,000,000 rows, no data
        np.lib.format.write_array_header_1_0(
            fh, {"descr": "<f8", "fortran_order": False, "shape": (2_000_000, 6)}
        )
    with pytest.raises(TaskFileError, match="2,000,000 wrenches, more than"):
        TaskRequirement.load(path)


# --- what save writes, load reads back identically --------------------------------------------
JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**12), 10**12)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(), inner, max_size=3),
    max_leaves=8,
)
FLOATS = st.floats(allow_nan=False, allow_infinity=False, width=64)


@ROUND_TRIP
@given(
    name=st.text(min_size=1, max_size=20)  # a task's name is never empty
    | st.sampled_from(["a\nb", "\r\n", " x ", '"q"', "# f_max: 3", "\u2028", "é\x00"]),
    f_max=st.floats(min_value=1e-300, max_value=1e12, exclude_min=False),
    kind=st.sampled_from(TASK_KINDS),
    rows=st.lists(st.lists(FLOATS, min_size=6, max_size=6), min_size=1, max_size=4),
    meta=st.dictionaries(st.text(max_size=8), JSON_VALUES, max_size=3),
    suffix=st.sampled_from([".json", ".csv"]),
)
def test_save_then_load_gives_the_same_task(tmp_path, name, f_max, kind, rows, meta, suffix):
    task = TaskRequirement(rows, name=name, f_max=f_max, kind=kind, meta=meta)
    back = TaskRequirement.load(task.save(tmp_path / f"task{suffix}", force=True))  # each example
    assert back == task and back.name == name and back.kind == kind
    assert back.f_max == f_max and math.copysign(1, back.f_max) == 1
    assert back.wrenches.tobytes() == task.wrenches.tobytes()  # -0.0 kept too
    assert json.dumps(back.meta, sort_keys=True) == json.dumps(meta, sort_keys=True)


@ROUND_TRIP
@given(rows=st.lists(st.lists(FLOATS, min_size=6, max_size=6), min_size=1, max_size=4))
def test_npy_keeps_the_exact_wrenches(tmp_path, rows):
    task = TaskRequirement(rows, name="w")
    back = TaskRequirement.load(task.save(tmp_path / "w.npy", force=True))  # each example
    assert back == task and back.wrenches.tobytes() == task.wrenches.tobytes()
