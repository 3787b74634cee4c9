"""Files a newcomer may mix up: a structure export read as a task gets a refusal that says what
it is; the listing of the shipped examples says which two are one task in two formats; and the
README's and the design page's commands write no file of the same name (following both pages
in order replaces nothing and asks for no --force)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from test_hardening import run_main

import modquad_gym as mq
from modquad_gym.sim.export import save_structure

ROOT = Path(__file__).resolve().parents[1]


def test_a_structure_export_read_as_a_task_is_named_for_what_it_is(tmp_path, capsys):
    path = tmp_path / "screwdriver.json"
    save_structure(mq.Structure([(0, 0), (0, 1), (1, 0)]), path)
    capsys.readouterr()  # its note that it cannot lift itself at f_max 1 N
    said = "this looks like a structure export (written by `modquad export`), not a task"
    with pytest.raises(ValueError, match=re.escape(said)):
        mq.TaskRequirement.load(str(path))
    code, _, err = run_main(capsys, "solve", "--task", str(path))
    assert code == 2 and err.count("\n") == 1 and f"{path}: {said}" in err


def test_the_example_listing_says_which_examples_are_one_task(capsys):
    code, out, _ = run_main(capsys, "task", "example")
    lines = {line.split()[0]: line for line in out.splitlines()}
    assert code == 0 and "(the task paper_seed0 as CSV)" in lines["paper_seed0.csv"]
    assert "(the task" not in lines["paper_seed0"] + lines["screwdriver"]


def _written(page: Path) -> set[str]:
    """The files the page's bash blocks write with --out (folders end in /)."""
    blocks = re.findall(r"```bash\n(.*?)```", page.read_text(), re.S)
    return {m for block in blocks for m in re.findall(r"--out (\S+)", block)}


def test_the_readme_and_the_design_page_write_different_files():
    readme = _written(ROOT / "README.md")
    design = _written(ROOT / "docs" / "getting-started" / "design.md")
    stems = lambda names: {Path(n).stem for n in names if not n.endswith("/")}  # noqa: E731
    assert readme and design
    # by stem: README's export also writes .json (a structure) where the page's task copy did
    assert not stems(readme) & stems(design)
