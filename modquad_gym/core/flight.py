"""Ray tasks that run in the background while this process goes on working (the anytime
search's producers on workers): :func:`launch` starts them, :class:`Flight` collects them."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from modquad_gym.core.distributed import (
    DEFAULT_RETRIES,
    Engine,
    Failed,
    ray_error_line,
    run_item,
)
from modquad_gym.core.extras import import_optional
from modquad_gym.core.validation import check_int


def launch(engine: Engine, fn: Callable, items: Sequence[Any], in_flight: int) -> Flight:
    """Start ``fn`` over ``items`` as Ray tasks of ``engine`` without waiting for them (a
    :class:`Flight`: use it as a context manager; Ray stays up until it closes). At most
    ``in_flight`` run at once; the others start, in item order, as those finish. An exception
    raised by ``fn`` comes back as a :class:`~.distributed.Failed` record. Needs Ray
    (``engine.use_ray``): a serial engine has no background to run in."""
    if not engine.use_ray:
        raise RuntimeError("launch needs an engine with Ray (use_ray is False)")
    return Flight(engine, fn, items, check_int(in_flight, "in_flight", low=1))


class Flight:
    """Ray tasks running in the background (:func:`launch`): collect what finished with
    :meth:`ready`, stop the rest with :meth:`close`."""

    def __init__(self, engine: Engine, fn: Callable, items: Sequence[Any], in_flight: int) -> None:
        self.engine = engine.__enter__()
        engine.start()
        ray = import_optional("ray")
        self._remote = ray.remote(num_cpus=1, max_retries=DEFAULT_RETRIES, retry_exceptions=False)(
            run_item
        )
        self._fn = ray.put(fn)
        self._waiting = list(enumerate(items))[::-1]  # popped from the end: item order
        self._index: dict[Any, int] = {}
        self._in_flight = in_flight
        self._fill()

    def _fill(self) -> None:
        while self._waiting and len(self._index) < self._in_flight:
            i, item = self._waiting.pop()
            self._index[self._remote.remote(self._fn, item, str(i), True)] = i

    @property
    def done(self) -> bool:
        """Whether every task has finished (and been collected)."""
        return not self._index and not self._waiting

    def ready(self, timeout: float = 0.0) -> list[tuple[int, Any]]:
        """(index, result) of the tasks that finished, waiting up to ``timeout`` seconds for the
        first one (0: only those already done); a task whose worker died past its retries
        comes back as a :class:`Failed` record."""
        if not self._index:
            return []
        ray = import_optional("ray")
        refs = list(self._index)
        done, _ = ray.wait(refs, num_returns=1, timeout=max(0.0, timeout))
        if done:  # and whatever else finished meanwhile
            done, _ = ray.wait(refs, num_returns=len(refs), timeout=0)
        out = []
        for ref in done:
            i = self._index.pop(ref)
            try:
                out.append((i, ray.get(ref)))
            except ray.exceptions.RayError as exc:
                out.append((i, Failed(str(i), ray_error_line(exc))))
        self._fill()
        return out

    def close(self) -> None:
        """Cancel what still runs or waits; Ray stops when no other block holds it."""
        ray = import_optional("ray")
        for ref in self._index:
            ray.cancel(ref, force=True)
        self._index.clear()
        self._waiting.clear()
        self.engine.__exit__(None, None, None)

    def __enter__(self) -> Flight:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
