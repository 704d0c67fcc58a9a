"""A progress bar with the time left, on stderr: redrawn in place on a terminal, otherwise one
line per tenth of the work (logs stay short).

Computing loops report through a plain callback ``progress(done, total)`` (``None``: quiet, as
when they are called from Python or tests); the command that runs them passes :class:`Bars`,
which draws a :class:`Progress` of the command's unit for each pass."""
from __future__ import annotations

import sys
import time


def clock_text(seconds: float) -> str:
    """``[h:]mm:ss`` of a duration in seconds."""
    seconds = int(round(seconds))
    h, rest = divmod(seconds, 3600)
    return (f"{h}:" if h else "") + f"{rest // 60:02d}:{rest % 60:02d}"


class _Closing:
    """A context manager that calls ``close()`` on leaving."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Progress(_Closing):
    """``update(done)`` after each finished batch (of ``unit``: points of a study, samples of a
    run); the rate counts this run's ones only. A context manager (closed on leaving)."""

    def __init__(self, total: int, resumed: int = 0, enabled: bool = True, stream=None,
                 width: int = 30, unit: str = "points"):
        self.total, self.resumed, self.width, self.unit = total, resumed, width, unit
        self.stream = stream or sys.stderr
        self.enabled = enabled and total > 0
        self.tty = self.enabled and self.stream.isatty()
        self.start = time.perf_counter()
        self._last_draw = 0.0
        self._last_tenth = -1
        self._drawn = self._finished = False
        if self.enabled and resumed:
            print(f"resuming: {resumed} of {total} {unit} already done", file=self.stream)

    def line(self, done: int) -> str:
        elapsed = time.perf_counter() - self.start
        new = done - self.resumed
        eta = (self.total - done) * elapsed / new if new > 0 else float("nan")
        fill = int(self.width * done / self.total)
        return (f"[{'#' * fill}{'.' * (self.width - fill)}] {done}/{self.total} {self.unit} "
                f"{clock_text(elapsed)} elapsed, ETA " + (clock_text(eta) if eta == eta
                                                          else "--:--"))

    def update(self, done: int) -> None:
        """Draw ``done`` of the total (on a terminal at most every 0.1 s); the total ends the
        bar (its line on a terminal), later calls draw nothing."""
        if not self.enabled or self._finished:
            return
        now = time.perf_counter()
        tenth = 10 * done // self.total
        if self.tty and (now - self._last_draw > 0.1 or done == self.total):
            self.stream.write("\r" + self.line(done))
            self.stream.flush()
            self._last_draw, self._drawn = now, True
        elif not self.tty and tenth > self._last_tenth:
            print(self.line(done), file=self.stream, flush=True)
            self._last_tenth = tenth
        if done >= self.total:
            self._finished = True
            self.close()

    def close(self) -> None:
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False


def run_each(jobs, unit: str) -> list:
    """Call each of ``jobs`` (callables without arguments) in turn, with a :class:`Progress`
    of ``unit`` counting them; their results, in order."""
    results = []
    with Progress(len(jobs), unit=unit) as bar:
        for job in jobs:
            results.append(job())
            bar.update(len(results))
    return results


class Bars(_Closing):
    """The ``progress(done, total)`` callback of a command: a :class:`Progress` of ``unit`` for
    each pass of the loop it is given to (a new bar when ``total`` changes or ``done`` goes
    back). A context manager (the last bar closed on leaving)."""

    def __init__(self, unit: str):
        self.unit = unit
        self.bar: Progress | None = None
        self._done = 0

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None or total != self.bar.total or done < self._done:
            self.close()
            self.bar = Progress(total, unit=self.unit)
        self._done = done
        self.bar.update(done)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
