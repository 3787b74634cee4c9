"""The progress line of a search that keeps an incumbent and a bound (the anytime search) on
stderr, e.g. ``anytime: 23 modules found (moves), bound 19 (gap 17 %), 4.2 s``.

On a terminal tqdm draws the line in place (its text is the whole bar: ``bar_format="{desc}"``);
a daemon thread redraws it every :data:`REDRAW_SECONDS` so that the clock moves while a search
works between events (tqdm redraws only on an update). In a log (not a terminal) each event is
a line of its own, without tqdm's carriage returns. ``--quiet`` and ``--json`` show nothing
(:func:`progress_line` is not enabled).
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from collections.abc import Iterator
from typing import TextIO

from modquad_gym.core.compile_clock import now
from modquad_gym.search.result import Improvement, SearchRun

REDRAW_SECONDS = 0.5
"""The line is looked at this often between events: redrawn on a terminal, so the clock moves
while a producer works; in a log, an event held back by :data:`BURST_SECONDS` is written."""

BURST_SECONDS = 0.2
"""Events closer than this to the last line drawn wait for the next one (local moves shrink an
incumbent by dozens of modules in a tenth of a second): a log gets a few lines a second; the
last event is always shown."""


def describe(method: str, event: Improvement, seconds: float, found_by: str = "") -> str:
    """One line: the incumbent and who found it (``found_by``, default the event's source),
    the proved bound, the gap, the time."""
    n, bound = event.n_modules, event.lower_bound
    if n is None:
        return f"{method}: no structure yet, bound {bound}, {seconds:.1f} s"
    gap = "certified" if n == bound else f"gap {100.0 * (n - bound) / n:.0f} %"
    by = found_by or event.source
    return f"{method}: {n} modules found ({by}), bound {bound} ({gap}), {seconds:.1f} s"


class ProgressLine:
    """Shows a run's latest :class:`Improvement` on ``stream``: redrawn in place on a terminal,
    one line per event elsewhere (a log); bursts thinned (:data:`BURST_SECONDS`), a daemon
    thread catching up every :data:`REDRAW_SECONDS`. Call :meth:`close` at the end."""

    def __init__(self, run: SearchRun, stream: TextIO | None = None) -> None:
        self.run = run
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.last: Improvement | None = None
        self.found_by = ""  # the source of the event that set the incumbent
        self._shown: Improvement | None = None
        self._drawn_at = -float("inf")
        self._bar = None  # the tqdm line on a terminal, made at the first event
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._ticker = threading.Thread(target=self._tick, daemon=True)
        self._ticker.start()

    def __call__(self, event: Improvement) -> None:
        with self._lock:
            if self.last is None or event.n_modules != self.last.n_modules:
                self.found_by = event.source
            self.last = event
            due = time.perf_counter() - self._drawn_at >= BURST_SECONDS
        if due:
            self._draw()

    def _tick(self) -> None:
        while not self._stop.wait(REDRAW_SECONDS):
            self._draw(only_new=not self.tty)

    def _draw(self, only_new: bool = False) -> None:
        with self._lock:
            event = self.last
            if event is None or (only_new and event is self._shown):
                return
            self._drawn_at = time.perf_counter()
            self._shown = event
            seconds = now() - self.run.t0 if self.tty else event.seconds  # a log: when it happened
            line = describe(self.run.method, event, seconds, self.found_by)
            if self.tty:
                if self._bar is None:
                    from tqdm import tqdm

                    self._bar = tqdm(file=self.stream, bar_format="{desc}", dynamic_ncols=True)
                self._bar.set_description_str(line)  # redrawn in place now
            else:
                self.stream.write(line + "\n")
                self.stream.flush()

    def close(self) -> None:
        """Stop redrawing and show the last event (on a terminal, end the line)."""
        self._stop.set()
        self._ticker.join()
        if self.last is None:
            return
        self._draw(only_new=not self.tty)
        if self._bar is not None:
            self._bar.close()  # leaves the line and ends it


@contextlib.contextmanager
def progress_line(run: SearchRun, enabled: bool) -> Iterator[None]:
    """While inside, ``run``'s improvements are shown on stderr when ``enabled``."""
    if not enabled:
        yield
        return
    line = ProgressLine(run)
    run.listener = line
    try:
        yield
    finally:
        run.listener = None
        line.close()
