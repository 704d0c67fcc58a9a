"""SIGINT and SIGTERM at any moment of a node's life: clean exit, status 0, no traceback.

Light on purpose (standard library only): it is installed before a node imports numpy, scipy or
rclpy, which take seconds on a loaded machine. The phases:

* **start-up** (interpreter start to the node's ``main``): a signal ends the process at once
  with status 0 -- nothing has been opened yet that would need finishing;
* **running** (:func:`rotor_avc.nodes.runtime.run_node`: building the node, waiting for
  discovery, the run): the first signal only asks the spin loop to stop after the current
  callback, so files (a bag) are finished on the way out; a second one unwinds at once through
  the same clean shutdown (:class:`Stop`);
* **shutting down** (:func:`shutting_down`): signals are ignored until the process has exited;
* processes started by :func:`spawn` begin with both signals *blocked* (the mask is inherited
  through ``exec``), so a signal sent before the interpreter has run a line stays pending and is
  handled by :func:`install` as it unblocks them -- no window in which the default action
  (death by signal, exit status -15/-2) applies.

A node module run with ``python -m rotor_avc.nodes.<node>`` or as a console script named after a
node installs the handlers from ``rotor_avc/nodes/__init__.py``, before its own imports.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

SIGNALS = (signal.SIGINT, signal.SIGTERM)
NODE_NAMES = ("plant_simulator", "foot_controller", "synchronous_controller",
              "harmonic_controller", "balancer", "recorder")


class Stop(BaseException):
    """Raised by a second SIGINT/SIGTERM while running: unwinds to the clean shutdown."""


_state = {"phase": "idle", "requested": False}


def _handler(signum, frame):
    if _state["phase"] == "shutting down":
        return
    if _state["phase"] == "startup":
        sys.stdout.flush()
        os._exit(0)
    if _state["requested"]:
        raise Stop(signum)
    _state["requested"] = True


def install() -> None:
    """Handle SIGINT/SIGTERM from now on (start-up phase), then unblock them."""
    if _state["phase"] == "idle":
        _state["phase"] = "startup"
    for sig in SIGNALS:
        signal.signal(sig, _handler)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)


def running() -> None:
    """The node's main has begun: signals now request a clean stop (see the module docstring)."""
    install()
    _state["phase"] = "running"
    _state["requested"] = False


def shutting_down() -> None:
    """The node is shutting down: later signals are ignored, so that none can interrupt the
    shutdown (a bag being finished) or, arriving while the interpreter finalises (which resets
    Python-level handlers to the default action), turn a clean exit into death by signal. The
    phase is set first and the signals are blocked while the dispositions change, so that a
    signal arriving in between is neither raised nor lost to the default action."""
    _state["phase"] = "shutting down"
    signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    for sig in SIGNALS:
        signal.signal(sig, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)


def stop_requested() -> bool:
    return _state["requested"]


def started_as_node() -> bool:
    """This interpreter is starting a node: ``python -m rotor_avc.nodes.<node>`` (``sys.argv``
    is ``['-m', ...]`` while the module is located) or a console script named after a node."""
    return sys.argv[:1] == ["-m"] or Path(sys.argv[0] if sys.argv else "").name in NODE_NAMES


def spawn(cmd: list[str], **popen_kwargs) -> subprocess.Popen:
    """``subprocess.Popen(cmd)`` with SIGINT/SIGTERM blocked in the child until it installs its
    handlers (above); the caller's own mask is restored at once."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        return subprocess.Popen(cmd, **popen_kwargs)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
