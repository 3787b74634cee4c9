"""What a module type and a structure accept: spins of +-1 only, lengths within the certificate
checker's limit, arrays of numbers of the right shape (each refusal a one-line ValueError
naming the field), and a disconnected-cells error that names the detached part."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.geometry.module import ModuleType
from modquad_gym.proofcheck_format import MAX_LENGTH

P = np.array([[1, 1, 0], [-1, 1, 0], [-1, -1, 0], [1, -1, 0]]) * 0.1
D = np.tile([0.0, 0.0, 1.0], (4, 1))
S = [1, -1, 1, -1]


def refused(make) -> str:
    with pytest.raises(ValueError) as info:
        make()
    text = str(info.value)
    assert "\n" not in text and len(text) < 300, text
    return text


@pytest.mark.parametrize("bad", [0.5, 2.0, 0.0, -3.0, float("nan"), float("inf")])
def test_spins_other_than_plus_or_minus_one_are_refused(bad):
    """Documented as +1 or -1: any other value would make A disagree with the JSON export's
    integer spins (and NaN would poison A without naming spins)."""
    text = refused(lambda: ModuleType(P, D, [bad, -1, 1, -1]))
    assert text.startswith("spins must each be +1 or -1") and repr(float(bad)) in text


def test_every_shipped_type_has_spins_of_plus_or_minus_one():
    from modquad_gym.geometry.module import STOCK_TYPES

    for m in [*STOCK_TYPES.values(), mq.TModule(), mq.TModule(0.3)]:
        assert set(np.abs(m.spins).tolist()) == {1.0}
        assert ModuleType(m.positions, m.directions, m.spins).digest  # still accepted


@pytest.mark.parametrize(
    "field, kwargs",
    [
        ("side", {"side": MAX_LENGTH * 1.5}),
        ("side", {"side": 1e160}),
        ("height", {"height": MAX_LENGTH * 1.5}),
        ("c_tau", {"c_tau": MAX_LENGTH * 1.5}),
    ],
)
def test_lengths_beyond_the_checkers_limit_are_refused(field, kwargs):
    """The certificate checker's own limit on a type's lengths (proofcheck_format.MAX_LENGTH):
    a side of 1e160 m used to give a structure NaN inertia and the JSON export NaN."""
    text = refused(lambda: ModuleType(P, D, S, **kwargs))
    assert text.startswith(f"{field} must be <= {MAX_LENGTH:g}")
    assert ModuleType(P, D, S, **{field: MAX_LENGTH}).n_rotors == 4  # the limit itself is kept


def test_positions_beyond_the_checkers_limit_are_refused():
    text = refused(lambda: ModuleType(P * (MAX_LENGTH * 15), D, S))
    assert text.startswith(f"positions must be finite, each coordinate within +-{MAX_LENGTH:g} m")
    with pytest.raises(ValueError, match="^side must be <="):
        ModuleType.from_tilts([0.5, -0.5, 0.5, -0.5], side=MAX_LENGTH * 2)


def test_a_huge_mass_is_refused_before_its_inertia_could_overflow():
    text = refused(lambda: ModuleType(P, D, S, side=MAX_LENGTH, mass=1e308))
    assert text == "mass must be <= 1e+12, got 1e+308"


@pytest.mark.parametrize("row", [[1e300, 1e300, 1e300], [1e200, 0.0, 0.0]])
def test_a_direction_whose_length_overflows_is_refused_naming_type_and_rotor(row):
    """Normalised, it became a zero rotor (columns of zeros) with only numpy's overflow warning
    (review 22); a shorter vector along it is accepted."""
    dirs = D.copy()
    dirs[2] = row
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning on the way
        text = refused(lambda: ModuleType(P, dirs, S, name="big"))
    assert text.startswith("directions[2] (rotor 3 of module type 'big') has a length that ")
    assert "overflows" in text
    dirs[2] = shorter = np.asarray(row) * 1e-150
    assert np.allclose(ModuleType(P, dirs, S).directions[2], shorter / np.linalg.norm(shorter))


@pytest.mark.parametrize("row", [[0.0, 0.0, 0.0], [float("nan"), 0.0, 1.0], [float("inf"), 0, 0]])
def test_a_zero_or_non_finite_direction_names_type_and_rotor(row):
    dirs = D.copy()
    dirs[1] = row
    text = refused(lambda: ModuleType(P, dirs, S))
    assert text.startswith("directions[1] (rotor 2 of module type 'module') must be finite and")


@pytest.mark.parametrize(
    "field, args, shape",
    [
        ("positions", ([["a", 0, 0], *P[1:].tolist()], D, S), "(r, 3)"),
        ("positions", (P[:, :2], D, S), "(r, 3)"),
        ("directions", (P, [[0, 0, 1], [0, 1], [0, 0, 1], [0, 0, 1]], S), "(4, 3)"),
        ("directions", (P, D[:3], S), "(4, 3)"),
        ("spins", (P, D, ["a", 1, 1, 1]), "(4,)"),
        ("spins", (P, D, [True, False, True, False]), "(4,)"),
        ("spins", (P, D, [1, -1, 1]), "(4,)"),
    ],
)
def test_arrays_that_are_not_numbers_or_of_the_wrong_shape_name_the_field(field, args, shape):
    text = refused(lambda: ModuleType(*args))
    assert text.startswith(f"{field} must be a {shape} array of numbers"), text


@pytest.mark.parametrize("bad", ["abc", [["1", "0", "0"]] * 3, [[1, 0], [0, 1]]])
def test_an_inertia_that_is_not_a_3_by_3_array_of_numbers_names_it(bad):
    text = refused(lambda: ModuleType(P, D, S, inertia=bad))
    assert text.startswith("inertia must be a") and "(3, 3)" in text


def test_the_disconnected_cells_error_names_the_detached_cell_and_stays_short():
    cells = [(i, 0) for i in range(100)] + [(0, 5)]
    text = refused(lambda: mq.Structure(cells))
    assert "cell #101 (0, 5) is not connected to cell #1 (0, 0)" in text
    assert "2 parts (100, 1 cells)" in text
    apart = [(2 * i, 0) for i in range(120)]  # 120 parts: the sizes are cut short
    text = refused(lambda: mq.Structure(apart))
    assert "cell #2 (2, 0)" in text and "120 parts (1, 1, 1, 1, 1, ... cells)" in text
    text = refused(lambda: mq.Structure([(0, 0), (5, 5), (1, 0)]))
    assert "cell #2 (5, 5)" in text and "2 parts (2, 1 cells)" in text
