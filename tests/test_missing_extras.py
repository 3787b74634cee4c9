"""A missing extra is named, in the command line's words, before any work: by the commands
whose output needs it (MJCF from ``export`` and ``solve --export``) and by the Python functions
that need it (``core.extras``: "an error that names the extra")."""

from __future__ import annotations

import importlib
import importlib.util
import sys

import pytest

import modquad_gym as mq
from modquad_gym import cli
from modquad_gym.core.extras import missing_extra_message

MJCF_COMMANDS = [
    ["export", "--task", "example:screwdriver", "--format", "mjcf", "--out", "a.xml"],
    ["export", "--task", "example:screwdriver", "--out", "b.xml"],
    ["export", "--cells", "[[0,0],[1,0]]", "--out", "c.xml"],
    ["solve", "--task", "example:screwdriver", "--export", "d.xml"],
]
"""Commands that write MJCF (by --format or by the .xml suffix): MuJoCo writes it."""


def hide_from_find_spec(monkeypatch, missing: str) -> None:
    """``importlib.util.find_spec`` finds no ``missing`` (as on a core install)."""
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == missing else real(name, *a))  # fmt: skip


def block_imports(monkeypatch, top: str) -> None:
    """``top`` and its submodules cannot be imported in this test (None in sys.modules)."""
    for name in [m for m in sys.modules if m == top or m.startswith(top + ".")] + [top]:
        monkeypatch.setitem(sys.modules, name, None)


@pytest.mark.parametrize("argv", MJCF_COMMANDS, ids=lambda a: " ".join(a[:1] + a[-2:]))
def test_mjcf_output_without_mujoco_is_refused_before_the_search(
    argv, tmp_path, monkeypatch, capsys
):
    """Without MuJoCo an MJCF export says so in one line, exit 2, in place of searching up to
    its time limit and refusing after (nothing searched, printed or written)."""
    from modquad_gym.cli import solve

    searched = []
    real = solve.solver
    monkeypatch.setattr(solve, "solver", lambda *a, **k: searched.append(a) or real(*a, **k))
    monkeypatch.chdir(tmp_path)
    hide_from_find_spec(monkeypatch, "mujoco")
    code = cli.main(argv)
    out, err = capsys.readouterr()
    assert code == 2 and err == f"modquad: error: {missing_extra_message('mujoco')}\n", err
    assert "modquad_gym[sim]" in err and not out and not searched
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize(
    "argv",
    [["export", "--task", "example:screwdriver", "--out", "a.urdf"],
     ["export", "--task", "example:screwdriver", "--format", "json", "--out", "a.json"],
     ["solve", "--task", "example:screwdriver", "--export", "b.json"]],
)  # fmt: skip
def test_urdf_and_json_exports_need_no_mujoco(argv, tmp_path, monkeypatch, capsys):
    """The formats of the core install are still written where MuJoCo is missing."""
    monkeypatch.chdir(tmp_path)
    hide_from_find_spec(monkeypatch, "mujoco")
    assert cli.main(argv) == 0, capsys.readouterr().err
    assert (tmp_path / argv[-1]).is_file()


def test_python_functions_name_the_missing_sim_extra(tmp_path, monkeypatch):
    """Without MuJoCo, the model, the validation, the MJCF export and the flight of an export
    raise the command line's ImportError naming ``[sim]``; validate raises it before the
    oracle runs, save_structure before writing anything."""
    from modquad_gym import sim
    from modquad_gym.sim.export import mjcf_text, save_structure, urdf_spec
    from modquad_gym.sim.export_flight import fly_mjcf

    validation = importlib.import_module("modquad_gym.sim.validate")  # not sim.validate, a function
    s = mq.Structure([(0, 0), (1, 0), (0, 1)])
    worked = []
    monkeypatch.setattr(validation, "feasible", lambda *a, **k: worked.append(a))
    block_imports(monkeypatch, "mujoco")
    calls = {
        "build_model": lambda: sim.build_model(s),
        "validate": lambda: sim.validate(s, [[0, 0, 2.0, 0, 0, 0]]),
        "save_structure .xml": lambda: save_structure(s, tmp_path / "py.xml"),
        "mjcf_text": lambda: mjcf_text(s),
        "urdf_spec": lambda: urdf_spec("<robot name='r'/>"),
        "fly_mjcf": lambda: fly_mjcf("<mujoco/>"),
    }
    for name, call in calls.items():
        with pytest.raises(ImportError) as err:
            call()
        assert str(err.value) == missing_extra_message("mujoco"), name
        assert "pip install 'modquad_gym[sim]'" in str(err.value), name
    assert not worked and not any(tmp_path.iterdir())


def test_python_pictures_name_the_missing_viz_extra(tmp_path, monkeypatch):
    """Without plotly the interactive page, without matplotlib the PNG: each raises the
    command line's ImportError naming ``[viz]``, with no file written."""
    from modquad_gym.viz import interactive
    from modquad_gym.viz.drawing import save_structure_figure

    s = mq.Structure([(0, 0), (1, 0), (0, 1)])
    for missing, call in [
        ("plotly", lambda: interactive.save_structure_page(s, tmp_path / "p.html")),
        ("matplotlib", lambda: save_structure_figure(s, tmp_path / "p.png")),
    ]:
        with monkeypatch.context() as patch:
            block_imports(patch, missing)
            with pytest.raises(ImportError) as err:
                call()
        assert str(err.value) == missing_extra_message(missing)
        assert "pip install 'modquad_gym[viz]'" in str(err.value)
    assert not any(tmp_path.iterdir())
