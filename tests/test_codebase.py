"""The consolidation's measures (``python -m benchmarks.codebase``): lines in the wheel and
branches on a task's kind outside the task model."""

from __future__ import annotations

from benchmarks.codebase import kind_branches, line_counts, main


def test_kind_branches_are_found_in_code_not_in_docstrings_or_the_task_model(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "tasks").mkdir(parents=True)
    (pkg / "search").mkdir()
    (pkg / "tasks" / "model.py").write_text('def f(task):\n    return task.kind == "total"\n')
    (pkg / "search" / "a.py").write_text(
        'def g(task, kind):\n    """When task.kind == "external" ...\n    more."""\n'
        "    if isinstance(task, DynamicTask):  # a branch\n        return 1\n"
        '    # task.kind == "total" in a comment\n'
        '    return kind == "external"\n'
    )
    found = kind_branches(pkg)
    assert [(f, n) for f, n, _ in found] == [("modquad_gym/search/a.py", 4),
                                             ("modquad_gym/search/a.py", 7)]  # fmt: skip


def test_line_counts_split_every_line(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "core").mkdir(parents=True)
    (pkg / "core" / "m.py").write_text('"""Doc\nstring."""\n\nX = 1\n"""X\'s doc."""\n')
    rows = line_counts(pkg)
    assert rows[-1] == {"folder": "total", "files": 1, "lines": 5, "docstrings": 3, "blank": 1,
                        "code": 1}  # fmt: skip


def test_the_report_is_written_and_refuses_to_replace_unasked(tmp_path, capsys):
    assert main(["--out", str(tmp_path)]) == 0
    assert "Python in the wheel" in (tmp_path / "codebase.md").read_text()
    try:
        main(["--out", str(tmp_path)])
    except SystemExit as exc:
        assert exc.code == 2
    assert "--force" in capsys.readouterr().err
