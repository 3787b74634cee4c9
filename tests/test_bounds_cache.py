"""The level bounds' disk cache: a cached file used as it was, with numbers scaled by 0.1,
would turn a certified minimum of 5 modules into a "certified minimum" of 6; one of another
shape would stop the search with a numpy error naming no file, one of strings with a traceback.
So a file is used only when its format, shape, type and checksum match; anything else is
recomputed and rewritten."""

from __future__ import annotations

import io

import numpy as np
import pytest

import modquad_gym as mq
from modquad_gym.search import bounds as bounds_module
from modquad_gym.search import bounds_cache
from modquad_gym.search.bounds import level_bounds, level_directions
from modquad_gym.tasks import PaperTasks

MODULE = mq.TModule()
"""The default module: its intact bounds ship; those after a rotor failure are cached."""


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty MODQUAD_CACHE, and no bounds held in memory before or after the test."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("MODQUAD_CACHE", str(folder))
    bounds_module._bounds.cache_clear()
    yield folder
    bounds_module._bounds.cache_clear()


def fresh_bounds(n: int) -> np.ndarray:
    """The rotor-failure bounds of level n as a new process would read them."""
    bounds_module._bounds.cache_clear()
    return level_bounds(MODULE, n, "rotor")


def npy_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def scaled(path, factor: float) -> None:
    """The bounds in ``path`` times ``factor``, written back in the file's own format (an .npy
    array, or an .npz whose other entries stay as they were)."""
    loaded = np.load(path)
    if isinstance(loaded, np.ndarray):
        path.write_bytes(npy_bytes(loaded * factor))
        return
    with loaded:
        arrays = {key: loaded[key] for key in loaded.files}
    arrays["bounds"] = arrays["bounds"] * factor
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    path.write_bytes(buffer.getvalue())


def test_scaled_cached_bounds_are_recomputed_and_the_certificate_stays(cache):
    """The cached bounds of level 5 scaled by 0.1 would make the exhaustive search skip
    level 5 and certify 6 modules: the checksum finds the change."""
    task = PaperTasks()(np.random.default_rng(1))
    first = mq.exhaustive_search(task, n_max=6, fault="rotor")
    assert first.certified and first.n_modules == 5
    files = sorted(cache.iterdir())
    assert files, "the rotor-failure bounds are cached"
    truth = {path.name: fresh_bounds(int(path.stem.rsplit("_n", 1)[1])) for path in files}
    for path in files:
        scaled(path, 0.1)
    bounds_module._bounds.cache_clear()
    again = mq.exhaustive_search(task, n_max=6, fault="rotor")
    assert (again.n_modules, again.certified) == (5, True)
    for path in files:  # rewritten as computed
        n = int(path.stem.rsplit("_n", 1)[1])
        assert np.array_equal(fresh_bounds(n), truth[path.name])
        assert bounds_cache.read_cached(path, len(level_directions())) is not None


BAD_FILES = {
    "another shape": npy_bytes(np.zeros((3, 7))),
    "strings": npy_bytes(np.array(["a", "b"])),
    "garbage": b"\x93NUMPY garbage",
    "empty": b"",
    "an npz of the wrong keys": None,  # filled below (needs np.savez)
}


def _npz(**arrays) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


BAD_FILES["an npz of the wrong keys"] = _npz(bounds=np.zeros((2, 104)))


@pytest.mark.parametrize("what", sorted(BAD_FILES))
def test_a_cached_file_of_another_kind_is_recomputed(cache, what):
    """Another shape gave "operands could not be broadcast" naming no file; an array of strings
    a traceback. Every such file now reads as absent: recomputed, rewritten, no error."""
    truth = fresh_bounds(3)
    (path,) = cache.iterdir()
    path.write_bytes(BAD_FILES[what])
    got = fresh_bounds(3)
    assert got.dtype == np.float64 and np.array_equal(got, truth)
    assert bounds_cache.read_cached(path, len(level_directions())) is not None


def test_the_format_and_checksum_are_checked(tmp_path, monkeypatch):
    """A file of another format (earlier code) or whose checksum or shape does not match reads
    as absent; the writer's own file reads back equal."""
    path = tmp_path / "b.npz"
    bounds = np.abs(np.random.default_rng(0).normal(size=(2, 104)))
    bounds_cache.write_cached(path, bounds)
    assert np.array_equal(bounds_cache.read_cached(path, 104), bounds)
    assert bounds_cache.read_cached(path, 105) is None  # another number of directions
    monkeypatch.setattr(bounds_cache, "FORMAT", bounds_cache.FORMAT + 1)
    assert bounds_cache.read_cached(path, 104) is None
    monkeypatch.undo()
    changed = bounds.copy()
    changed[1, 7] *= 1 + 1e-12
    path.write_bytes(_npz(bounds=changed, format=np.int64(bounds_cache.FORMAT),
                          sha256=np.str_(bounds_cache.checksum(bounds))))  # fmt: skip
    assert bounds_cache.read_cached(path, 104) is None
    negative = -bounds
    path.write_bytes(_npz(bounds=negative, format=np.int64(bounds_cache.FORMAT),
                          sha256=np.str_(bounds_cache.checksum(negative))))  # fmt: skip
    assert bounds_cache.read_cached(path, 104) is None


def test_the_shipped_bounds_pass_the_array_check():
    """The shipped file is read without a checksum (it ships with the code) but must hold
    arrays of the cache's shape and type."""
    for n in range(1, 15):
        assert bounds_cache.usable(bounds_module._shipped(bounds_module.module_digest(MODULE), n),
                                   len(level_directions()))  # fmt: skip
