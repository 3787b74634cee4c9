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


def test_pair_failures_name_every_failed_rotor_in_words_and_title():
    """A two-rotor failure names both rotors, a module-and-rotor failure the module and the
    rotor (review 23 F6); the picture's title says the kind in words."""
    import modquad_gym as mq
    from modquad_gym.sim.fault_flight import fly_with_failure
    from modquad_gym.sim.fault_pictures import _title

    task = mq.TaskRequirement.load("examples/screwdriver.json")
    s = mq.Structure([(0, 0), (0, 1), (1, 0), (2, 0)])
    for fault in ("rotor2", "rotor+module"):
        flight = fly_with_failure(s, task, fault, failure="worst", seconds=1.1)
        r = flight.summary()
        words = "\n".join(fault_lines(r)) + fault_markdown(r, 4)
        cols = r["fault_failed_rotors"]
        named = list(zip(r["fault_failed_parts"], cols))  # a module's own rotors: by the module
        for where, c in named if fault == "rotor2" else named[-1:]:
            said = f"rotor {where['rotor_in_module'] + 1} of module {where['module'] + 1}"
            assert said in words and f"cell {tuple(s.cells[where['module']])}" in words
            assert c - 4 * where["module"] == where["rotor_in_module"]
        if fault == "rotor2":
            assert f"rotors {cols[0] + 1} and {cols[1] + 1} (" in words
            assert "any two-rotor failure" in _title(flight, "")
        else:
            m = r["fault_failed_module"]
            assert f"module {m + 1} at cell {tuple(s.cells[m])} and rotor {cols[-1] + 1} (" in words
            assert "any module-and-rotor failure" in _title(flight, "")


def test_a_one_module_structure_loses_the_module_alone_under_rotor_and_module():
    """A one-module structure's rotor+module failure is the module alone (its own rotors,
    nothing else is left to fail): the words name the module, no extra rotor."""
    import numpy as np

    import modquad_gym as mq
    from modquad_gym.sim.fault_flight import fly_with_failure
    from modquad_gym.sim.fault_pictures import failed_part_words

    s = mq.Structure([(0, 0)])
    r = fly_with_failure(s, np.array([[0, 0, 0.5, 0, 0, 0]]), "rotor+module", seconds=1.1,
                         failure="worst").summary()  # fmt: skip
    assert r["fault_failed_rotors"] == list(range(s.modules[0].n_rotors))  # the module alone
    assert failed_part_words(r) == "module 1 at cell (0, 0)"
    assert "module 1 at cell (0, 0) stopped" in "\n".join(fault_lines(r))
    assert "and rotor" not in "\n".join(fault_lines(r)) + fault_markdown(r, 1)
