"""The study engine: evaluate every point of a point set with one evaluator, on a backend.

A study is a :class:`~rotor_avc.studies.spec.StudySpec`: a point set (:class:`~rotor_avc.studies.points.Grid` or
:class:`~rotor_avc.studies.points.Sample`) and an *evaluator*, an object with

* ``prepare() -> context``: the work shared by all points (e.g. a gain study's plant), done
  once per worker process;
* ``evaluate(context, point) -> dict``: the small record of one point, a pure function of the
  configuration and the point (same inputs, same bits, on any worker);
* ``fields``: ``{name: float | int | str | bool}`` of the record (what the output files hold;
  ``None`` for in-memory studies whose records hold arrays);
* ``describe() -> dict``: what identifies the study (config, settings) for resuming.

Points are evaluated in batches of consecutive indices, each batch doing about
:data:`TASK_TARGET_S` of work (the cost per point is measured on the first points, evaluated in
this process), in at most :data:`MAX_TASKS` batches, unless the batch size is given. A point
that raises is recorded with its error (``"Type: message"``) and the study goes on. With an
output folder, finished points are journaled as they arrive and a study started again on the
same folder computes only the points not yet there (:mod:`rotor_avc.studies.output`).
Ctrl-C or SIGTERM stops a study at a clean point (:mod:`rotor_avc.studies.interrupt`): the
workers are stopped and the tables of the finished points written.
"""
from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ConfigError
from ..resources import check_memory, check_time
from .backends import SerialBackend
from .interrupt import check as check_stop, stop_on_signals
from .output import ResultStore
from .points import OUTCOME_BYTES
from .progress import Progress
from .spec import Outcome, StudySpec, evaluate_batch

#: work per task (s): long enough that scheduling overhead (~1 ms per task) is below 1 %
TASK_TARGET_S = 0.1
#: at most this many tasks per study (bounds the scheduler's and this process's bookkeeping)
MAX_TASKS = 10_000
#: time spent measuring the cost per point in this process before the backend takes over (s)
CALIBRATE_S = 0.1


@dataclass
class StudyRun:
    """The outcome of every point (by index) and how this run went."""

    outcomes: list[Outcome]
    computed: int                    # points evaluated in this run (the rest were resumed)
    cost_per_point_s: float | None   # measured on the first points (None: batch size given)
    batch_size: int
    elapsed_s: float
    files: list[Path] = field(default_factory=list)

    @property
    def failed(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.error is not None]


def batches_of(indices: list[int], size: int) -> list[list[int]]:
    return [indices[k:k + size] for k in range(0, len(indices), size)]


def run_study(spec: StudySpec, backend=None, out: Path | None = None, batch_size: int | None = None,
              progress: bool = True, on_outcome=None) -> StudyRun:
    """Evaluate every point of ``spec`` on ``backend`` (default: serial in this process).

    ``out``: folder for the incremental results (resumed when it holds a part of this study);
    ``batch_size``: points per task (default: about :data:`TASK_TARGET_S` of work per task, the
    cost measured on the first points here; given, every point goes to the backend);
    ``on_outcome(outcome)``: called in this process for every finished point."""
    if batch_size is not None and batch_size < 1:
        raise ConfigError("--batch-size", f"must be >= 1 (got {batch_size})",
                          fix="give --batch-size 10, or leave it out for about 0.1 s per task")
    backend = backend or SerialBackend()
    t0 = time.perf_counter()
    n = len(spec.points)
    check_memory(n * OUTCOME_BYTES, f"a study of {n} points", "use fewer points")
    store = ResultStore(Path(out), spec) if out is not None else None
    done: dict[int, Outcome] = dict(store.done) if store else {}
    todo = [i for i in range(n) if i not in done]
    bar = Progress(n, len(done), enabled=progress)
    computed = 0

    def record(batch: list[Outcome]) -> None:
        nonlocal computed
        fresh = [o for o in batch if o.index not in done]
        for o in fresh:
            done[o.index] = o
            if on_outcome is not None:
                on_outcome(o)
        if store:
            store.append(fresh)
        computed += len(fresh)
        bar.update(len(done))
        check_stop()

    cost, size = None, batch_size or 1
    with stop_on_signals():
        try:
            first, cost = (0, None) if batch_size or not todo else _calibrate(spec, todo, record)
            rest = todo[first:]
            if cost:
                workers = backend.workers
                check_time(cost * len(rest) / workers,
                           f"the study's {len(rest)} remaining points at {cost:.3g} s each on "
                           f"{workers} worker(s)", "use fewer points or more workers")
            size = batch_size or (max(math.ceil(TASK_TARGET_S / cost),
                                      math.ceil(len(rest) / MAX_TASKS)) if cost else 1)
            if rest:
                with contextlib.closing(backend.run(spec, batches_of(rest, size))) as results:
                    for batch in results:            # closed (workers stopped) on any exit
                        record(batch)
        finally:
            bar.close()
            files = store.finish() if store else []
    missing = [i for i in range(n) if i not in done]
    if missing:
        raise RuntimeError(f"the backend returned no result for {len(missing)} points "
                           f"(first: {missing[:5]})")
    return StudyRun([done[i] for i in range(n)], computed, cost, size,
                    time.perf_counter() - t0, files)


def _calibrate(spec: StudySpec, todo: list[int], record) -> tuple[int, float | None]:
    """Evaluate the first points of ``todo`` here until :data:`CALIBRATE_S` has passed (at
    least two points); the cost per point is the mean without the first (warm-up) point."""
    context = spec.evaluator.prepare()
    count, start, t_first = 0, time.perf_counter(), None
    while count < len(todo) and (count < 2 or time.perf_counter() - start < CALIBRATE_S):
        record(evaluate_batch(spec, context, [todo[count]]))
        count += 1
        if t_first is None:
            t_first = time.perf_counter()
    if count < 2:
        return count, time.perf_counter() - start
    return count, max((time.perf_counter() - t_first) / (count - 1), 1e-6)
