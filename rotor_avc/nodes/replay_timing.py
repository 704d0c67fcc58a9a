"""The clock of a timed replay: its absolute schedule (how well it was held), and a reader
thread that keeps the bag's next messages read ahead of it, so that reading a bag chunk (tens
of ms) does not hold a due message back."""
from __future__ import annotations

import queue
import sys
import threading
import time

#: a log time published more than this after its due time is late (counted and said)
LATE_S = 0.05
#: the interpreter's thread switch interval while the reader thread runs (Python's default,
#: 5 ms, would let it hold a due message back that long at every switch)
READ_AHEAD_SWITCH_S = 1e-4


class Schedule:
    """A timed replay's absolute schedule, from its first message on (the message logged at
    ``t`` is due at ``t_zero + (t - t_first) / rate``), and how well it was held."""

    def __init__(self, rate: float):
        self.rate = rate
        self.t_first: int | None = None
        self.t_zero = 0.0
        self.last: tuple[int, float] | None = None     # (log time, wall time) published last
        self.late = 0
        self.max_lag_s = 0.0

    def due(self, time_ns: int) -> float:
        if self.t_first is None:
            self.t_first, self.t_zero = time_ns, time.monotonic()
        return self.t_zero + (time_ns - self.t_first) * 1e-9 / self.rate

    def published(self, time_ns: int, due: float) -> None:
        now = time.monotonic()
        self.late += now - due > LATE_S
        self.max_lag_s = max(self.max_lag_s, now - due)
        self.last = (time_ns, now)

    def achieved_rate(self) -> float | None:
        """Recorded time over wall time from the first publication to the last; None without
        a recorded time span."""
        if self.last is None or self.last[0] <= self.t_first or self.last[1] <= self.t_zero:
            return None
        return (self.last[0] - self.t_first) * 1e-9 / (self.last[1] - self.t_zero)


def read_ahead(messages, depth: int):
    """The items of the generator ``messages``, read by a thread that keeps up to ``depth`` of
    them ahead of the consumer; the first is handed out once ``depth`` are read (or all), so a
    short selection is read whole before the schedule starts. An exception of the reading (a
    damaged chunk) is raised here. Closing this generator stops and joins the thread."""
    items: queue.Queue = queue.Queue(depth)
    stop, primed = threading.Event(), threading.Event()
    done = object()

    def put(item) -> bool:
        while not stop.is_set():
            try:
                items.put(item, timeout=0.1)
                if items.full():
                    primed.set()
                return True
            except queue.Full:
                primed.set()
        return False

    def read() -> None:
        try:
            for msg in messages:
                if not put(msg):
                    return
            put(done)
        except Exception as exc:          # handed to the consumer
            put(exc)
        finally:
            primed.set()
            close = getattr(messages, "close", None)     # a generator: its bag is closed
            if close is not None:
                close()

    thread = threading.Thread(target=read, name="replay_read_ahead", daemon=True)
    interval = sys.getswitchinterval()
    sys.setswitchinterval(READ_AHEAD_SWITCH_S)
    thread.start()
    try:
        primed.wait()
        while (item := items.get()) is not done:
            if isinstance(item, Exception):
                raise item
            yield item
    finally:
        stop.set()
        thread.join()
        sys.setswitchinterval(interval)
