"""Where the batches of a study run: in this process, in local processes, or on a Dask cluster.

Every backend evaluates the same batches with :func:`~rotor_avc.studies.spec.evaluate_batch`
and yields them as they finish (any order; the engine files every point by its index). The study
spec (points and evaluator) goes to each worker once -- a process pool's initializer, a Dask
``scatter(broadcast=True)`` -- and each worker prepares the evaluator's context (the base machine)
once per study and keeps it; a task carries only its point indices.

A local worker process ends with the process that started it, however that ends (``kill -9``
included: the kernel's parent-death signal on Linux, elsewhere a thread polling the parent), and
ignores Ctrl-C, which the study's own process handles. A Dask scheduler must answer within
:data:`SCHEDULER_TIMEOUT_S` (the TCP connection and Dask's handshake, each bounded): at the start,
and whenever no result has arrived for :data:`PROBE_S` -- so a scheduler that hangs is reported
within ``PROBE_S + SCHEDULER_TIMEOUT_S`` (20 s) of the last result. A cluster that loses every
worker loses the study's data with them and cancels its tasks, which ends the study at once.
"""
from __future__ import annotations

import asyncio
import ctypes
import os
import queue
import re
import signal
import socket
import sys
import threading
import time
import uuid
from concurrent.futures import (FIRST_COMPLETED, CancelledError, ProcessPoolExecutor,
                                ThreadPoolExecutor, wait)
from concurrent.futures.process import BrokenProcessPool

from ..errors import ConfigError, RotorAvcError
from .interrupt import POLL_S, check as check_stop
from .spec import StudySpec, describe_error, evaluate_batch

#: how long a Dask scheduler has to accept the connection, and then to answer (s)
SCHEDULER_TIMEOUT_S = 10.0
#: a study on Dask that has received no result for this long asks the scheduler (s)
PROBE_S = 10.0
#: prctl(2) option: the signal a process gets when its parent ends (Linux)
PR_SET_PDEATHSIG = 1

RESUME_HINT = ("the finished points are kept in the output folder's journal: run the same "
               "command again to resume")


class BackendError(RotorAvcError):
    """A worker or the cluster failed (not a point: a failing point is recorded)."""

#: per worker process: study token -> (spec, prepared context)
_PREPARED: dict[str, tuple[StudySpec, object]] = {}


def _prepared(token: str, spec: StudySpec | None = None):
    if token not in _PREPARED:
        _PREPARED.clear()                        # one study at a time per worker
        _PREPARED[token] = (spec, spec.evaluator.prepare())
    return _PREPARED[token]


def _die_with_parent() -> None:
    """End this process when its parent ends (module docstring)."""
    parent = os.getppid()
    watched = False
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            watched = libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:                   # the parent ended before the watch was set
        os._exit(1)
    if not watched:
        def poll():
            while os.getppid() == parent:
                time.sleep(1.0)
            os._exit(1)
        threading.Thread(target=poll, name="parent-watch", daemon=True).start()


def _process_init(token: str, spec: StudySpec) -> None:
    _die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)         # Ctrl-C is the study process's
    signal.signal(signal.SIGTERM, signal.SIG_DFL)        # not the study's handler, if inherited
    _prepared(token, spec)


def _process_batch(token: str, indices: list[int]):
    spec, context = _prepared(token)
    return evaluate_batch(spec, context, indices)


def _dask_batch(spec: StudySpec, token: str, indices: list[int]):
    spec, context = _prepared(token, spec)
    return evaluate_batch(spec, context, indices)


def available_cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


class SerialBackend:
    """Every batch in this process, in order."""

    workers = 1

    def run(self, spec: StudySpec, batches):
        context = spec.evaluator.prepare()
        for batch in batches:
            yield evaluate_batch(spec, context, batch)


class ProcessBackend:
    """A pool of ``workers`` local processes (default: one per core); a single batch runs here."""

    def __init__(self, workers: int | None = None):
        if workers is not None and workers < 1:
            raise ConfigError("--workers", f"must be >= 1 (got {workers})",
                              fix="give --workers 2, or leave it out for one per core")
        self.workers = workers or available_cores()

    def run(self, spec: StudySpec, batches):
        if len(batches) <= 1 or self.workers == 1:
            yield from SerialBackend().run(spec, batches)
            return
        token = uuid.uuid4().hex
        with ProcessPoolExecutor(min(self.workers, len(batches)), initializer=_process_init,
                                 initargs=(token, spec)) as pool:
            pending = {pool.submit(_process_batch, token, b) for b in batches}
            try:
                while pending:
                    check_stop()
                    finished, pending = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
                    broken = [f for f in finished if f.exception() is not None]
                    for fut in finished:
                        if fut.exception() is None:
                            yield fut.result()
                    if broken:
                        exc = broken[0].exception()
                        if not isinstance(exc, BrokenProcessPool):
                            raise exc
                        raise BackendError(f"a worker process stopped ({describe_error(exc)}); "
                                           + RESUME_HINT)
            finally:
                for fut in pending:
                    fut.cancel()


_ADDRESS = re.compile(r"tcp://(?P<host>[A-Za-z0-9](?:[A-Za-z0-9.-]*[A-Za-z0-9])?"
                      r"|\[[0-9A-Fa-f:.]+\]):(?P<port>[0-9]{1,5})")


def scheduler_host_port(address: str) -> tuple[str, int]:
    """``tcp://HOST:PORT`` -> (HOST, PORT); a ConfigError of ``--scheduler`` for anything else
    (an empty address included)."""
    match = _ADDRESS.fullmatch(address)
    if not match or not 1 <= int(match["port"]) <= 65535:
        raise ConfigError("--scheduler", f"{address!r} is not the address of a Dask scheduler",
                          fix="give tcp://HOST:PORT as `dask scheduler` prints it, e.g. "
                              "tcp://127.0.0.1:8786")
    return match["host"].strip("[]"), int(match["port"])


async def _identity(address: str) -> dict:
    from distributed.core import rpc

    async with rpc(address) as scheduler:
        return await scheduler.identity(n_workers=0)


def ask_scheduler(address: str, timeout_s: float) -> dict:
    """The scheduler's ``identity`` (``n_workers``, ...), the TCP connection and the answer each
    within ``timeout_s``; a ``str`` saying why not otherwise. (``distributed.Client``'s timeout
    bounds the connection only: a server that accepts and never answers would hold it for good.)
    """
    host, port = scheduler_host_port(address)
    try:
        socket.create_connection((host, port), timeout=timeout_s).close()
    except socket.gaierror as exc:
        return f"unknown host {host!r} ({exc.strerror})"
    except TimeoutError:
        return f"no connection within {timeout_s:g} s"
    except OSError as exc:
        return f"cannot connect: {exc.strerror or exc}"
    try:                                         # its own thread: the caller may run a loop
        with ThreadPoolExecutor(1) as thread:
            return thread.submit(
                lambda: asyncio.run(asyncio.wait_for(_identity(address), timeout_s))).result()
    except TimeoutError:
        return f"it accepted the connection but gave no Dask answer within {timeout_s:g} s"
    except Exception as exc:     # noqa: BLE001 -- whatever answered, it is no Dask scheduler
        return f"it did not answer as a Dask scheduler ({describe_error(exc)})"


class DaskBackend:
    """An existing Dask cluster (``dask scheduler`` + ``dask worker``s, each of which must import
    this package). Tasks are submitted with ``pure=False`` (Dask would otherwise merge calls with
    equal arguments); a task lost with a worker is run again on another one. The scheduler is
    checked at the start and while the study waits (module docstring)."""

    def __init__(self, address: str, timeout_s: float = SCHEDULER_TIMEOUT_S,
                 probe_s: float = PROBE_S):
        scheduler_host_port(address)
        try:
            from distributed import Client
        except ImportError:
            raise ConfigError("--scheduler", "dask.distributed is not installed",
                              fix="pip install distributed") from None
        self.address, self.timeout_s, self.probe_s = address, timeout_s, probe_s
        info = ask_scheduler(address, timeout_s)
        if isinstance(info, str):
            raise ConfigError("--scheduler", f"no Dask scheduler answered at {address}: {info}",
                              fix="start one (`dask scheduler`) and give its tcp://HOST:PORT")
        self.client = Client(address, timeout=timeout_s)
        try:
            self.client.wait_for_workers(1, timeout=timeout_s)
        except TimeoutError:
            self.client.close()
            raise ConfigError("--scheduler", f"the scheduler at {address} has no workers",
                              fix=f"start some: dask worker {address}") from None

    def _identity(self) -> dict:
        info = ask_scheduler(self.address, self.timeout_s)
        if isinstance(info, str):
            raise BackendError(f"the Dask scheduler at {self.address} stopped answering ({info}); "
                               + RESUME_HINT)
        return info

    @property
    def workers(self) -> int:
        return max(1, self._identity()["n_workers"])

    def _result(self, fut):
        """A finished task's result, fetched through the scheduler: its answer is awaited at
        most ``timeout_s`` at a time, the scheduler asked whether it is alive in between."""
        while True:
            try:
                return fut.result(timeout=self.timeout_s)
            except TimeoutError:
                self._identity()

    def run(self, spec: StudySpec, batches):
        token = uuid.uuid4().hex
        try:
            shared = self.client.scatter(spec, broadcast=True, hash=False, timeout=self.timeout_s)
        except TimeoutError:
            self._identity()
            raise BackendError(f"the study could not be sent to the workers of {self.address} "
                               f"within {self.timeout_s:g} s") from None
        futures = [self.client.submit(_dask_batch, shared, token, b, pure=False) for b in batches]
        finished: queue.SimpleQueue = queue.SimpleQueue()
        for fut in futures:
            fut.add_done_callback(finished.put)
        try:
            for _ in futures:
                quiet_since = time.monotonic()
                while True:
                    check_stop()
                    try:
                        fut = finished.get(timeout=POLL_S)
                        break
                    except queue.Empty:
                        if time.monotonic() - quiet_since >= self.probe_s:
                            self._identity()             # alive, or a BackendError
                            quiet_since = time.monotonic()
                try:
                    batch = self._result(fut)
                except BackendError:
                    raise
                except CancelledError as exc:
                    raise BackendError(
                        f"the cluster cancelled a task ({describe_error(exc)}): were its "
                        "workers lost, and the study's data with them? " + RESUME_HINT) from None
                except Exception as exc:     # noqa: BLE001 -- points do not raise: the cluster did
                    raise BackendError(
                        f"a task failed on the cluster ({describe_error(exc)}); check that every "
                        "worker has this package and its dependencies installed; "
                        + RESUME_HINT) from None
                yield batch
                fut.release()
        finally:
            self.client.cancel(futures)
            self.client.cancel(shared)

    def close(self) -> None:
        self.client.close(timeout=self.timeout_s)


#: the command-line options of :func:`backend_from_args` (argparse dest -> option)
BACKEND_OPTIONS = {"workers": "--workers", "scheduler": "--scheduler", "batch_size": "--batch-size"}


def check_scheduler_arg(scheduler: str | None) -> None:
    """Refuse a malformed ``--scheduler`` (one line, before any work)."""
    if scheduler is not None:
        scheduler_host_port(scheduler)


def backend_from_args(workers: int | None, scheduler: str | None):
    """``--scheduler tcp://HOST:PORT`` -> Dask; ``--workers 1`` -> serial; else local processes."""
    if scheduler is not None:
        check_scheduler_arg(scheduler)
        if workers is not None:
            raise ConfigError("--workers", "--workers and --scheduler both given",
                              fix="the cluster's workers run the study; leave out --workers")
        return DaskBackend(scheduler)
    return SerialBackend() if workers == 1 else ProcessBackend(workers)


def add_backend_arguments(p) -> None:
    """The command-line options of :func:`backend_from_args`."""
    p.add_argument("--workers", type=int, metavar="N",
                   help="local worker processes (default: one per core; 1 = in this process)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run on an existing Dask cluster (dask.distributed) instead; its "
                        f"scheduler must answer within {SCHEDULER_TIMEOUT_S:g} s")
    p.add_argument("--batch-size", type=int, metavar="N",
                   help="points per task (default: about 0.1 s of work per task)")
