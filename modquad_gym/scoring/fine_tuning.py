"""What PPO fine-tuning did, in words read off the run's own learning curve (the report never
claims a rise the numbers do not show)."""

from __future__ import annotations

import io
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from modquad_gym.core.validation import read_regular_file

MAX_EVALUATIONS_BYTES = 64 << 20
"""Most bytes of an ``evaluations.npz`` and of each array in it (a run's are a few kB)."""


def read_evaluations(path: Path) -> dict[str, np.ndarray]:
    """The arrays of a training run's ``evaluations.npz`` that the report reads, checked:
    ``timesteps`` (k,), ``results`` (k, n) and, when recorded, ``successes`` and ``optimal``
    (k, n; empty: not recorded), every one finite, k, n >= 1. Nothing is unpickled. A
    ValueError names ``path`` and the key: a bad file is refused before any scoring, not by
    the report after it."""
    raw = io.BytesIO(read_regular_file(path, MAX_EVALUATIONS_BYTES))
    if not zipfile.is_zipfile(raw):
        raise ValueError(f"{path}: not a NumPy .npz archive (as train.py writes it)")
    out: dict[str, np.ndarray] = {}
    try:
        with np.load(raw, allow_pickle=False) as data:
            keys = sorted(data.files)
            for key in ("timesteps", "results", "successes", "optimal"):
                if key in keys:
                    out[key] = _member(data, key, path)
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ValueError(f"{path}: not a readable .npz archive ({exc})") from None
    for key in ("timesteps", "results"):
        if key not in out:
            raise ValueError(f"{path}: no {key!r} array (keys: {', '.join(keys) or 'none'})")
    steps, results = out["timesteps"], out["results"]
    if steps.ndim != 1 or not len(steps):
        raise ValueError(f"{path}: 'timesteps' must have shape (k,), k >= 1, got {steps.shape}")
    if results.ndim != 2 or results.shape[0] != len(steps) or not results.shape[1]:
        raise ValueError(
            f"{path}: 'results' must have shape (k, n) = ({len(steps)}, n), n >= 1 (one row "
            f"per evaluation in 'timesteps'), got {results.shape}"
        )
    for key, arr in out.items():
        if key in ("successes", "optimal") and arr.size and arr.shape != results.shape:
            raise ValueError(
                f"{path}: {key!r} must have the shape of 'results', {results.shape}, got "
                f"{arr.shape}"
            )
        if not np.isfinite(arr).all():
            raise ValueError(f"{path}: {key!r} holds a value that is not finite")
    return out


def _member(data: Any, key: str, path: Path) -> np.ndarray:
    """The array ``key`` of the open archive ``data``: numbers (booleans for flags), read only
    within :data:`MAX_EVALUATIONS_BYTES`."""
    if data.zip.getinfo(key + ".npy").file_size > MAX_EVALUATIONS_BYTES:
        raise ValueError(f"{path}: {key!r} is larger than {MAX_EVALUATIONS_BYTES >> 20} MiB")
    try:
        arr = data[key]
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ValueError(f"{path}: {key!r} is not a readable array ({exc})") from None
    flags = key in ("successes", "optimal")
    if arr.dtype.kind not in ("biuf" if flags else "iuf"):
        raise ValueError(f"{path}: {key!r} must hold numbers, got dtype {arr.dtype}")
    return arr.astype(float) if arr.dtype.kind != "b" else arr


def fine_tuning_words(evals: Path, w_module: float = 0.1) -> str:
    """What PPO fine-tuning did, in the numbers of the run's ``evaluations.npz`` (step 0: the
    cloned policy, when the run cloned first): in validation tasks solved optimally when the
    file records them (``optimal``; the kept model is the one :func:`kept_index` picks),
    else in validation return, where a change below half of one module on one validation task
    (``w_module / n``, the reward's module cost) is reported as no rise: it is a partial share
    on a failed task, not a design."""
    data = read_evaluations(evals)
    steps, ret = data["timesteps"], data["results"].mean(axis=1)
    has_success = "successes" in data and data["successes"].size
    success = data["successes"].mean(axis=1) if has_success else None
    if not len(steps):
        return ""
    n_tasks = data["results"].shape[1]
    start = "the cloned policy's" if steps[0] == 0 else "the first evaluation's"
    if "optimal" in data and data["optimal"].size:
        best, kept = best_index(data), kept_index(data)
        p = replaces_start(data, best)[1] if kept != best else None
        opt = data["optimal"].sum(axis=1)
        return _optimal_words(steps, opt, success, n_tasks, start, best, kept, p)
    best = int(np.argmax(ret))  # the first evaluation of the highest mean return
    one_module = w_module / n_tasks

    def at(i: int) -> str:
        tail = f", success {f'{100 * float(success[i]):.1f} %'}" if success is not None else ""
        return f"{ret[i]:.4f} at step {int(steps[i])}{tail}"

    gain = ret[best] - ret[0]
    if gain < one_module / 2:
        return (
            f"PPO fine-tuning did not raise the validation return above {start} ({at(0)}) by "
            f"half a module on one of the {n_tasks} validation tasks ({one_module / 2:.4f}): "
            f"its best was {at(best)}, and it ended at {at(len(steps) - 1)} (learning curve)."
        )
    return (
        f"PPO fine-tuning raised the validation return from {start} {at(0)} to {at(best)} "
        f"({gain / one_module:.1f} modules over the {n_tasks} validation tasks) and ended at "
        f"{at(len(steps) - 1)} (learning curve); the kept model is the best."
    )


def best_index(data: Any) -> int:
    """The evaluation with the highest (optimal share, success rate, mean return), the first on
    ties; ``data``: an ``evaluations.npz`` (without ``optimal``: by mean return alone, as runs
    before the optimal share were kept)."""
    ret = np.asarray(data["results"], dtype=float).mean(axis=1)
    keys = [np.zeros_like(ret), np.zeros_like(ret), ret]
    for i, name in enumerate(("optimal", "successes")):
        if name in data and np.asarray(data[name]).size:
            keys[i] = np.asarray(data[name], dtype=float).mean(axis=1)
    rows = [tuple(np.round(k[i], 9) for k in keys) for i in range(len(ret))]
    return max(range(len(rows)), key=lambda i: (rows[i], -i))


SIGNIFICANCE = 0.05
"""The level at which the best checkpoint must beat the cloned start (:func:`kept_index`)."""


def replaces_start(data: Any, best: int, alpha: float = SIGNIFICANCE) -> tuple[bool, float]:
    """(whether evaluation ``best`` solves significantly more validation tasks optimally than
    step 0, its p-value): a one-sided exact McNemar test on the tasks where the two differ,
    at ``alpha`` over the number of evaluations after step 0 (Bonferroni: the best of many
    noisy evaluations beats its start by luck alone). ``optimal`` holds one flag per task in
    the same task order at every evaluation."""
    from scipy.stats import binomtest

    opt = np.asarray(data["optimal"], dtype=bool)
    gained = int((opt[best] & ~opt[0]).sum())
    lost = int((opt[0] & ~opt[best]).sum())
    if gained + lost == 0:
        return False, 1.0
    p = float(binomtest(gained, gained + lost, 0.5, alternative="greater").pvalue)
    return p < alpha / max(len(opt) - 1, 1), p


def kept_index(data: Any, alpha: float = SIGNIFICANCE) -> int:
    """The evaluation a run keeps: :func:`best_index`, except that a run that evaluated its
    cloned start at step 0 (``optimal`` recorded) keeps that start unless the best checkpoint
    :func:`replaces_start` significantly."""
    best = best_index(data)
    has_start = "optimal" in data and np.asarray(data["optimal"]).size and data["timesteps"][0] == 0
    if best == 0 or not has_start:
        return best
    return best if replaces_start(data, best, alpha)[0] else 0


def _optimal_words(steps, optimal, success, n_tasks, start, best, kept, p) -> str:
    """The sentence on a run that recorded its optimal shares (``p``: the test's p-value when
    the cloned start was kept over a better checkpoint)."""

    def at(i: int) -> str:
        tail = f", success {100 * float(success[i]):.1f} %" if success is not None else ""
        return f"{int(optimal[i])} of {n_tasks} optimal at step {int(steps[i])}{tail}"

    last = len(steps) - 1
    if optimal[best] <= optimal[0]:
        which = "that first one" if kept == 0 else f"step {int(steps[kept])}'s (as many optimal)"
        return (
            f"PPO fine-tuning did not solve more validation tasks optimally than {start} "
            f"({at(0)}): it ended at {at(last)} (learning curve); the kept model is {which}."
        )
    rise = (
        f"PPO fine-tuning raised the validation tasks solved optimally from {start} {at(0)} to "
        f"{at(best)} ({int(optimal[best] - optimal[0]):+d}) and ended at {at(last)} (learning "
        "curve); "
    )
    if kept == best:
        return rise + "the kept model is the best validation checkpoint."
    alpha = SIGNIFICANCE / max(last, 1)
    return rise + (
        f"that gain is within chance for the best of {last} evaluations (one-sided McNemar "
        f"p = {p:.3f}, needed < {alpha:.4f}), so the kept model is the cloned start."
    )
