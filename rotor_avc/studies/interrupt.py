"""Stopping a running study at a clean point.

While :func:`stop_on_signals` is active (in the main thread), the first Ctrl-C (SIGINT) or
SIGTERM (``kill``, ``timeout``) only sets a flag; the engine and the backends read it between
points and while they wait for results (every :data:`POLL_S`) and raise KeyboardInterrupt there.
An exception raised by the signal handler itself could land inside the locks of a process pool
and leave one held, so the study would hang instead of stopping. A second signal interrupts at
once. Either way the engine journals nothing more, stops the workers and writes the tables of
the finished points; the command line ends with exit status 130.
"""
from __future__ import annotations

import contextlib
import signal
import threading

#: longest wait between two looks at the flag while a backend waits for results (s)
POLL_S = 0.2

_requested = threading.Event()


def check() -> None:
    """Raise KeyboardInterrupt if a stop was asked for."""
    if _requested.is_set():
        raise KeyboardInterrupt


@contextlib.contextmanager
def stop_on_signals():
    """Inside, in the main thread: SIGINT and SIGTERM set the flag (module docstring); a
    signal for which the program has its own handler is left alone."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        if _requested.is_set():
            raise KeyboardInterrupt
        _requested.set()

    previous = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        current = signal.getsignal(sig)
        if current in (signal.SIG_DFL, signal.default_int_handler):
            previous[sig] = signal.signal(sig, handler)
    _requested.clear()
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
        _requested.clear()
