"""Where the batches of a study run: in this process, in local processes, or on a Dask cluster.

Every backend evaluates the same batches with :func:`~rotor_avc.studies.spec.evaluate_batch`
and yields them as they finish (any order; the engine files every point by its index). The study
spec (points and evaluator) goes to each worker once -- a process pool's initializer, a Dask
``scatter(broadcast=True)`` -- and each worker prepares the evaluator's context (the base machine)
once per study and keeps it; a task carries only its point indices.
"""
from __future__ import annotations

import os
import uuid
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from ..errors import ConfigError, RotorAvcError
from .spec import StudySpec, describe_error, evaluate_batch

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


def _process_init(token: str, spec: StudySpec) -> None:
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
                    finished, pending = wait(pending, return_when=FIRST_COMPLETED)
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


class DaskBackend:
    """An existing Dask cluster (``dask scheduler`` + ``dask worker``s, each of which must import
    this package). Tasks are submitted with ``pure=False`` (Dask would otherwise merge calls with
    equal arguments); a task lost with a worker is run again on another one."""

    def __init__(self, address: str, timeout_s: float = 10.0):
        try:
            from distributed import Client
        except ImportError:
            raise ConfigError("--scheduler", "dask.distributed is not installed",
                              fix="pip install distributed") from None
        try:
            self.client = Client(address, timeout=timeout_s)
        except (OSError, TimeoutError) as exc:
            raise ConfigError("--scheduler", f"no Dask scheduler answered at {address} ({exc})",
                              fix="start one (`dask scheduler`) and give its tcp://HOST:PORT") from None
        try:
            self.client.wait_for_workers(1, timeout=timeout_s)
        except TimeoutError:
            self.client.close()
            raise ConfigError("--scheduler", f"the scheduler at {address} has no workers",
                              fix=f"start some: dask worker {address}") from None

    @property
    def workers(self) -> int:
        return max(1, len(self.client.scheduler_info()["workers"]))

    def run(self, spec: StudySpec, batches):
        from distributed import as_completed

        token = uuid.uuid4().hex
        shared = self.client.scatter(spec, broadcast=True, hash=False)
        futures = [self.client.submit(_dask_batch, shared, token, b, pure=False) for b in batches]
        try:
            for fut in as_completed(futures):
                try:
                    batch = fut.result()
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
        self.client.close()


def backend_from_args(workers: int | None, scheduler: str | None):
    """``--scheduler tcp://HOST:PORT`` -> Dask; ``--workers 1`` -> serial; else local processes."""
    if scheduler:
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
                   help="run on an existing Dask cluster (dask.distributed) instead")
    p.add_argument("--batch-size", type=int, metavar="N",
                   help="points per task (default: about 0.1 s of work per task)")
