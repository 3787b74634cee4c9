"""The library's notes go through logging (logger ``modquad_gym``): one line on the stderr of
the moment by default, silenced by the logger's level, and independent of the root logger."""

from __future__ import annotations

import logging

import pytest

from modquad_gym.core.resources import cap_workers


@pytest.fixture
def package_log():
    log = logging.getLogger("modquad_gym")
    level = log.level
    yield log
    log.setLevel(level)


def test_a_note_is_one_line_on_stderr_and_the_logger_silences_it(package_log, capsys, monkeypatch):
    monkeypatch.setattr("modquad_gym.core.resources.usable_cpus", lambda: 2)
    other = logging.StreamHandler()  # another library's handler on the root logger
    other.setFormatter(logging.Formatter("ROOT %(levelname)s %(message)s"))
    logging.getLogger().addHandler(other)
    try:
        assert cap_workers(8) == 2
        err = capsys.readouterr().err
        assert err == (
            "modquad: note: --workers 8: this machine has 2 usable CPU(s); running 2 at a time\n"
        )
        package_log.setLevel(logging.ERROR)
        assert cap_workers(8) == 2
        assert capsys.readouterr().err == ""
    finally:
        logging.getLogger().removeHandler(other)
