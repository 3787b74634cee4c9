"""``python -m benchmarks.coldstart``: its ``solve --method ppo`` runs from any folder (a shipped
example, no repository file), and what its report says about torch is what it measured."""

from __future__ import annotations

import os
import subprocess
import sys

from benchmarks import coldstart


def test_the_ppo_command_runs_anywhere_and_imports_no_training_stack(tmp_path, monkeypatch):
    """The measured command exits 0 from an empty folder, and ``-X importtime`` finds none of
    torch and SB3 in it: the shipped model acts through its NumPy export."""
    monkeypatch.chdir(tmp_path)
    assert coldstart.heavy_imports({**os.environ, "OMP_NUM_THREADS": "1"}) == []


def test_the_report_says_what_was_imported():
    """The report's sentence follows the measurement, not a fixed claim."""
    assert "imported none of torch" in coldstart.torch_statement([])
    said = coldstart.torch_statement(["torch"])
    assert "imported torch." in said and "none of" not in said


def test_the_numba_row_calls_compiled_code():
    """The "first numba dispatch" row times a call that loads numba (small levels enumerate in
    plain Python and would time nothing of numba's)."""
    code = coldstart.NUMBA_CODE + "import sys; print('numba' in sys.modules)\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split()[-1] == "True"
