import math
from collections import Counter

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.geometry.structure import configuration_matrices, normalise, structure_levels


def all_structures(n_max):
    return [key for level in structure_levels(n_max) for key in level]


def test_single_t_module_columns():
    eta = math.pi / 4
    A = mq.Structure([(0, 0)]).configuration_matrix()
    assert A.shape == (6, 4)
    np.testing.assert_allclose(np.linalg.norm(A[:3], axis=0), 1.0)  # unit thrust columns
    np.testing.assert_allclose(A[2], math.cos(eta))  # z-components cos(eta)
    np.testing.assert_allclose(A[:2].sum(axis=1), 0.0, atol=1e-12)  # horizontal thrusts cancel
    assert np.linalg.matrix_rank(A) == 4
    assert mq.Structure([(0, 0)]).rank == 4


@pytest.mark.parametrize("eta", [0.1, math.pi / 6, math.pi / 4, 1.0])
def test_t_module_tilt_is_about_the_arm(eta):
    m = mq.TModule(eta=eta)
    for p, d in zip(m.positions, m.directions):
        assert abs(p @ d) < 1e-12  # tilting about the arm keeps thrust orthogonal to the arm
        assert d[2] == pytest.approx(math.cos(eta))


def test_structure_counts_up_to_translation():
    assert [len(level) for level in structure_levels(8)] == [1, 2, 6, 19, 63, 216, 760, 2725]


def test_every_structure_up_to_5_is_torque_balanced_with_rank_classes():
    eta = math.pi / 4
    for key in all_structures(5):
        s = mq.Structure(key)
        A = s.configuration_matrix()
        assert s.is_torque_balanced()
        total = A.sum(axis=1)
        assert total[2] == pytest.approx(4 * s.n_modules * math.cos(eta))  # total lift
        np.testing.assert_allclose(total[[0, 1, 3, 4, 5]], 0.0, atol=1e-12)
        xs = {c[0] for c in key}
        ys = {c[1] for c in key}
        straight = len(xs) == 1 or len(ys) == 1
        if s.n_modules == 1:
            assert s.rank == 4
        elif straight:
            assert s.rank == 5, key
        else:
            assert s.rank == 6, key


def test_rank_class_counts():
    counts = {
        n: Counter(mq.Structure(k).rank for k in level)
        for n, level in enumerate(structure_levels(4), start=1)
    }
    assert counts[3] == Counter({6: 4, 5: 2})
    assert counts[4] == Counter({6: 17, 5: 2})


def test_translation_invariance_and_key():
    a = mq.Structure([(0, 0), (1, 0), (1, 1)])
    b = mq.Structure([(5, -3), (6, -3), (6, -2)])
    np.testing.assert_allclose(a.configuration_matrix(), b.configuration_matrix())
    assert a.key == b.key == ((0, 0), (1, 0), (1, 1))
    assert a == b and hash(a) == hash(b)
    c = mq.Structure([(0, 0), (0, 1), (1, 1)])  # a reflection: a different structure
    assert c != a


def test_frame_is_at_com_and_partner():
    s = mq.Structure([(0, 0), (1, 0), (2, 0)])
    np.testing.assert_allclose(s.module_centres.mean(axis=0), 0.0, atol=1e-15)
    assert s.module_centres[0, 0] == pytest.approx(-0.4)
    assert s.centrosymmetric_partner((0, 1)) == (2, -1)
    assert mq.Structure([(0, 0), (1, 0)]).centrosymmetric_partner((0, 1)) == (1, -1)
    assert mq.Structure([(0, 0), (1, 0), (0, 1)]).centrosymmetric_partner((1, 1)) is None
    assert s.is_centrosymmetric()
    assert not mq.Structure([(0, 0), (1, 0), (0, 1)]).is_centrosymmetric()


def test_attachable_cells_and_text():
    s = mq.Structure([(0, 0), (1, 0)])
    assert s.attachable_cells() == [(-1, 0), (0, -1), (0, 1), (1, -1), (1, 1), (2, 0)]
    assert s.to_text() == "[@][#]"
    assert "n_modules=2" in repr(s)
    assert mq.Structure([(0, 0), (0, 1)]).to_text() == "[#]\n[@]"


def test_configuration_matrices_follow_eq_1_column_by_column():
    """Eq. (1) written out from rotor positions and directions, against the batched builder
    (which Structure.configuration_matrix() also uses)."""
    level = list(structure_levels(5))[-1]
    As = configuration_matrices(level)
    for key, A in zip(level[::7], As[::7]):
        s = mq.Structure(key)
        spins = np.tile(s.module.spins, s.n_modules)
        for k, (p, d) in enumerate(zip(s.rotor_positions, s.rotor_directions)):
            torque = np.cross(p, d) + spins[k] * s.module.c_tau * d
            np.testing.assert_allclose(A[:, k], np.r_[d, torque], atol=1e-15)
        np.testing.assert_array_equal(A, s.configuration_matrix())


def test_general_module_type_from_tilts():
    m = mq.ModuleType.from_tilts((0.3, -0.3, 0.3, -0.3))
    np.testing.assert_allclose(m.columns, mq.TModule(0.3).columns)
    flat = mq.ModuleType.from_tilts((0, 0, 0, 0))
    s = mq.Structure([(0, 0), (1, 0), (0, 1)], module=flat)
    assert s.rank == 4  # vertical rotors: only thrust and three torques
    assert s.is_torque_balanced()


@pytest.mark.parametrize(
    "cells, message",
    [
        ([], "at least one cell"),
        ([(0, 0), (0, 0)], "duplicate cells"),
        ([(0, 0), (0.5, 0)], "must hold integers"),
        ([(0, 0), ("a", 0)], "must hold integers"),
        ([(0, 0), (2, 0)], "not face-connected"),
        ([(0, 0), (1, 1)], "not face-connected"),
        ([(0, 0, 0)], "not a pair"),
    ],
)
def test_bad_cells_raise(cells, message):
    with pytest.raises(ValueError, match=message):
        mq.Structure(cells)


def test_bad_module_values_raise():
    with pytest.raises(ValueError, match="tilts"):
        mq.ModuleType.from_tilts((0.1, 0.2))
    with pytest.raises(ValueError, match="eta"):
        mq.TModule(eta=float("nan"))
    with pytest.raises(ValueError, match="side"):
        mq.TModule(side=-1.0)


def test_normalise_is_translation_only():
    assert normalise([(3, 4), (4, 4)]) == ((0, 0), (1, 0))
    assert normalise([(3, 4), (3, 5)]) == ((0, 0), (0, 1))


def test_import_is_light():
    """`import modquad_gym` loads no numba, torch, SB3, Ray, MuJoCo, scipy or environment module
    (they load where they are used; the ids register by entry-point strings). Its time is
    reported, not asserted: speed belongs to benchmarks (benchmarks/startup.py)."""
    import subprocess
    import sys

    code = (
        "import sys, time; t = time.perf_counter(); import modquad_gym; "
        "print(time.perf_counter() - t, *sorted(m for m in ('torch', 'stable_baselines3', "
        "'sb3_contrib', 'mujoco', 'numba', 'ray', 'scipy', 'gymnasium', 'numpy', "
        "'modquad_gym.envs.assembly.env', "
        "'modquad_gym.search', 'modquad_gym.oracle') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    seconds, *heavy = out.stdout.split()
    assert heavy == [], f"import modquad_gym ({float(seconds):.2f} s) loaded {heavy}"


def test_public_names_resolve_and_match_all():
    """Every lazily loaded public name resolves, and ``__all__`` lists exactly them."""
    import modquad_gym as mq
    import modquad_gym.envs.assembly as assembly

    for package in (mq, assembly):
        table = sorted(n for names in package._NAMES.values() for n in names)
        assert sorted(package.__all__) == table
        assert all(getattr(package, name) is not None for name in table)
        assert set(table) <= set(dir(package))


def test_small_levels_enumerate_in_plain_python_in_the_compiled_order(monkeypatch):
    """Levels up to PLAIN_UP_TO cells run the enumeration without numba; the compiled run of
    the same function gives the same canonical order."""
    import modquad_gym.geometry.polyominoes as poly

    for n in range(1, poly.PLAIN_UP_TO + 1):
        plain = np.concatenate(list(poly.PolyominoStream(n, 100)))
        monkeypatch.setattr(poly, "PLAIN_UP_TO", 0)
        compiled = np.concatenate(list(poly.PolyominoStream(n, 100)))
        monkeypatch.undo()
        assert len(plain) == poly.A001168[n - 1] and np.array_equal(plain, compiled)


def test_ids_register_when_gymnasium_is_imported_after_the_package():
    """``import modquad_gym`` then ``import gymnasium``: the ids are registered by then."""
    import subprocess
    import sys

    code = (
        "import sys, modquad_gym; assert 'gymnasium' not in sys.modules; "
        "import gymnasium as gym; env = gym.make('ModQuadAssembly-v0'); "
        "print(env.spec.reward_threshold, 'ModQuadAssemblyFaultTolerant-v0' in gym.registry)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["0.4", "True"]
