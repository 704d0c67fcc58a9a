"""A progress bar with the time left, on stderr: redrawn in place on a terminal, otherwise one
line per tenth of the study (logs stay short)."""
from __future__ import annotations

import sys
import time


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    h, rest = divmod(seconds, 3600)
    return (f"{h}:" if h else "") + f"{rest // 60:02d}:{rest % 60:02d}"


class Progress:
    """``update(done)`` after each finished batch (of ``unit``: points of a study, samples of a
    run); the rate counts this run's ones only."""

    def __init__(self, total: int, resumed: int = 0, enabled: bool = True, stream=None,
                 width: int = 30, unit: str = "points"):
        self.total, self.resumed, self.width, self.unit = total, resumed, width, unit
        self.stream = stream or sys.stderr
        self.enabled = enabled and total > 0
        self.tty = self.enabled and self.stream.isatty()
        self.start = time.perf_counter()
        self._last_draw = 0.0
        self._last_tenth = -1
        self._drawn = False
        if self.enabled and resumed:
            print(f"resuming: {resumed} of {total} {unit} already done", file=self.stream)

    def line(self, done: int) -> str:
        elapsed = time.perf_counter() - self.start
        new = done - self.resumed
        eta = (self.total - done) * elapsed / new if new > 0 else float("nan")
        fill = int(self.width * done / self.total)
        return (f"[{'#' * fill}{'.' * (self.width - fill)}] {done}/{self.total} {self.unit} "
                f"{_clock(elapsed)} elapsed, ETA " + (_clock(eta) if eta == eta else "--:--"))

    def update(self, done: int) -> None:
        if not self.enabled:
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

    def close(self) -> None:
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
