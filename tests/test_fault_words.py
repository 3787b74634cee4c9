"""The failed part of a fault flight is numbered from 1 in every sentence, as the command line
numbers task rows and cells (the record keeps the 0-based index into ``cells``)."""

from __future__ import annotations

from modquad_gym.cli.validate_fault import fault_lines
from modquad_gym.sim.validate_fault import fault_markdown

RECORD = {
    "fault": "rotor", "fault_flight": "hover", "fault_tolerates": True,
    "fault_worst_margin": 0.1, "fault_failed_module": 1, "fault_failed_cell": [0, 1],
    "fault_failed_rotor_in_module": 1, "fault_time_s": 1.0, "fault_detection_delay_s": 0.0,
    "fault_max_position_error_m": 0.01, "fault_saturated_fraction": 0.0, "fault_diverged": None,
}  # fmt: skip


def test_the_console_and_the_report_number_the_failed_rotor_from_one():
    said = "rotor 2 of module 2 at cell (0, 1)"  # cells[1], its rotor 1 (0-based)
    assert said in "\n".join(fault_lines(RECORD))
    assert said in fault_markdown(RECORD, 4)
    module = {**RECORD, "fault": "module", "fault_failed_rotor_in_module": None}
    line = "\n".join(fault_lines(module))
    assert "; module 2 at cell (0, 1) stopped" in line and "of module" not in line
