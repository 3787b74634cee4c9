"""Shared test set-up: one torch thread (DESIGN.md pitfall), headless rendering; a module
written for a test to import (:func:`importable`)."""

import importlib
import os
import sys

import pytest

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="module")
def importable(tmp_path_factory):
    """``importable(name, source)``: the module ``name`` written from ``source`` and imported
    (an outside agent the scoring loads by ``name:Class``), for the test module's tests; its
    folder leaves sys.path and the module sys.modules afterwards."""
    folder = tmp_path_factory.mktemp("importable")
    names: list[str] = []
    sys.path.insert(0, str(folder))

    def write(name: str, source: str):
        (folder / f"{name}.py").write_text(source)
        names.append(name)
        return importlib.import_module(name)

    yield write
    sys.path.remove(str(folder))
    for name in names:
        sys.modules.pop(name, None)
