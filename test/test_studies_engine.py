"""The study engine's bookkeeping (rotor_avc.studies.engine): batches, the batch size from the
measured cost per point, the time and memory estimates, counts and failures -- with an evaluator
that counts its own evaluations and a backend that records the batches it is given.

Hand computations: consecutive batches of ``size`` indices; with the cost per point ``c``
measured on the first points, batches of ``max(ceil(TASK_TARGET_S / c), ceil(rest / MAX_TASKS))``
points; the time estimate ``c * rest / workers``; the memory estimate ``n * OUTCOME_BYTES``.
"""
import math
import time
from dataclasses import dataclass, field

import numpy as np
import pytest

from rotor_avc.errors import ConfigError
from rotor_avc.studies import engine
from rotor_avc.studies.backends import SerialBackend
from rotor_avc.studies.engine import StudySpec, batches_of, run_study
from rotor_avc.studies.points import OUTCOME_BYTES, ValueList


@dataclass
class Counting:
    """``y = 2 g``; point values above ``fail_above`` raise; ``pause_s`` of work per point; every
    evaluated index kept in ``seen`` (in-process backends only)."""

    fail_above: float = math.inf
    pause_s: float = 0.0
    seen: list = field(default_factory=list)
    fields = {"y": float}

    def prepare(self):
        return None

    def evaluate(self, context, point):
        self.seen.append(point.index)
        if self.pause_s:
            time.sleep(self.pause_s)
        g = point.values["g"]
        if g > self.fail_above:
            raise ValueError(f"g = {g:g} is too large")
        return {"y": 2.0 * g}

    def describe(self):
        return {"evaluator": "counting"}


class Recording(SerialBackend):
    """The serial backend, recording the batches; ``workers`` as given."""

    def __init__(self, workers=1):
        self.workers = workers
        self.batches = []

    def run(self, spec, batches):
        self.batches.extend(batches)
        yield from super().run(spec, batches)


def study(n, **kw):
    return StudySpec(ValueList("g", np.arange(n, dtype=float)), Counting(**kw))


def test_batches_are_consecutive_runs_of_the_size():
    assert batches_of(list(range(7)), 3) == [[0, 1, 2], [3, 4, 5], [6]]
    assert batches_of([4, 9, 11], 1) == [[4], [9], [11]]
    assert batches_of([4, 9, 11], 5) == [[4, 9, 11]]


@pytest.mark.parametrize("size", [1, 3, 10])
def test_a_given_batch_size_sends_every_point_to_the_backend_in_such_batches(size):
    spec, backend = study(10), Recording()
    run = run_study(spec, backend, batch_size=size, progress=False)
    assert backend.batches == batches_of(list(range(10)), size)
    assert spec.evaluator.seen == list(range(10))        # each point once, none here first
    assert run.batch_size == size and run.cost_per_point_s is None and run.computed == 10
    assert [o.record["y"] for o in run.outcomes] == [2.0 * i for i in range(10)]
    assert 0.0 <= run.elapsed_s < 60.0


@pytest.mark.parametrize("size", [0, -2])
def test_a_batch_size_below_one_is_refused(size):
    spec = study(3)
    with pytest.raises(ConfigError, match="--batch-size.*must be >= 1"):
        run_study(spec, batch_size=size, progress=False)
    assert spec.evaluator.seen == []


def test_the_batch_size_follows_the_measured_cost_per_point(monkeypatch):
    """10 ms per point: the first points are evaluated here for CALIBRATE_S = 0.1 s (at least
    two), the cost is measured as >= 10 ms, and the rest goes in batches of about
    TASK_TARGET_S / cost = 10 points (fewer when the cost is measured higher)."""
    estimates = []
    monkeypatch.setattr(engine, "check_time", lambda s, what, fix: estimates.append(s))
    spec, backend = study(60, pause_s=0.01), Recording(workers=4)
    run = run_study(spec, backend, progress=False)
    calibrated = 60 - sum(len(b) for b in backend.batches)
    # two points take 20 ms of the 100: the measuring goes on beyond them
    assert 3 <= calibrated <= 11 and spec.evaluator.seen == list(range(60))
    assert [i for b in backend.batches for i in b] == list(range(calibrated, 60))
    cost = run.cost_per_point_s
    assert 0.01 <= cost < 0.05
    assert run.batch_size == math.ceil(engine.TASK_TARGET_S / cost) and 2 <= run.batch_size <= 10
    assert all(len(b) == run.batch_size for b in backend.batches[:-1])
    (seconds,) = estimates
    assert seconds == pytest.approx(cost * (60 - calibrated) / 4, rel=1e-12)


def test_at_most_max_tasks_batches(monkeypatch):
    monkeypatch.setattr(engine, "TASK_TARGET_S", 1e-12)     # the cost alone: one point a batch
    monkeypatch.setattr(engine, "MAX_TASKS", 4)
    monkeypatch.setattr(engine, "CALIBRATE_S", 0.0)          # two points measured here
    spec, backend = study(50), Recording()
    run = run_study(spec, backend, progress=False)
    assert sum(len(b) for b in backend.batches) == 48
    assert run.batch_size == 12 and backend.batches == batches_of(list(range(2, 50)), 12)
    assert spec.evaluator.seen == list(range(50))


@pytest.mark.parametrize("n, size", [(10_002, 1), (10_003, 2)])
def test_at_most_10000_tasks_as_the_readme_states(monkeypatch, n, size):
    """Points of negligible cost, two measured here: 10,000 remaining points go one to a task,
    10,001 need batches of two (ceil(10001 / 10000) = 2: 5,001 tasks, not 10,001)."""
    monkeypatch.setattr(engine, "TASK_TARGET_S", 1e-12)
    monkeypatch.setattr(engine, "CALIBRATE_S", 0.0)
    spec, backend = study(n), Recording()
    run = run_study(spec, backend, progress=False)
    assert run.batch_size == size and len(backend.batches) == math.ceil((n - 2) / size) <= 10_000


def test_a_single_point_is_evaluated_here_and_measured():
    spec, backend = study(1), Recording()
    run = run_study(spec, backend, progress=False)
    assert spec.evaluator.seen == [0] and backend.batches == []
    assert run.cost_per_point_s is not None and run.cost_per_point_s > 0
    assert run.computed == 1 and run.outcomes[0].record == {"y": 0.0}


def test_failed_points_are_counted_and_passed_on_once():
    spec, seen = study(8, fail_above=4.5), []
    run = run_study(spec, Recording(), batch_size=3, progress=False, on_outcome=seen.append)
    assert [o.index for o in run.failed] == [5, 6, 7]
    assert all(o.error == f"ValueError: g = {o.index:g} is too large" for o in run.failed)
    assert sorted(o.index for o in seen) == list(range(8)) and len(seen) == 8
    assert run.computed == 8


def test_a_study_beyond_the_memory_limit_is_refused_before_any_work(monkeypatch):
    asked = []
    monkeypatch.setattr(engine, "check_memory",
                        lambda nbytes, what, fix: asked.append((nbytes, what)))
    run_study(study(7), progress=False)
    assert asked == [(7 * OUTCOME_BYTES, "a study of 7 points")]
    monkeypatch.undo()
    monkeypatch.setenv("ROTOR_AVC_MAX_MEMORY_GB", "1e-9")
    spec = study(7)
    with pytest.raises(Exception, match="a study of 7 points needs about"):
        run_study(spec, progress=False)
    assert spec.evaluator.seen == []


class FrozenClock:
    """A ``time`` module whose clock never advances."""

    @staticmethod
    def perf_counter():
        return 0.0


def test_a_clock_that_does_not_advance_gives_the_floor_cost(monkeypatch):
    """No time passes: the measuring runs through every point (0 s < CALIBRATE_S) and the cost
    per point is the floor 1e-6 s, not 0 (which would divide by zero in the batch size)."""
    monkeypatch.setattr(engine, "time", FrozenClock)
    spec = study(5)
    run = run_study(spec, Recording(), progress=False)
    assert spec.evaluator.seen == list(range(5)) and run.cost_per_point_s == 1e-6
    assert run.batch_size == math.ceil(engine.TASK_TARGET_S / 1e-6)


@dataclass
class Paced(Counting):
    """``Counting`` after ``pauses_s[index]`` of work (the first point: a warm-up)."""

    pauses_s: tuple = ()

    def evaluate(self, context, point):
        time.sleep(self.pauses_s[point.index])
        return super().evaluate(context, point)


def test_the_cost_per_point_leaves_out_the_first_points_warm_up():
    """Two points, 300 ms and 10 ms: the cost is the second one's (>= 10 ms, far below the 155 ms
    mean of both, with room for a busy machine's late wake-ups); one point of 20 ms: its own
    time."""
    run = run_study(StudySpec(ValueList("g", [0.0, 1.0]), Paced(pauses_s=(0.3, 0.01))), Recording(),
                    progress=False)
    assert 0.01 <= run.cost_per_point_s < 0.12
    run = run_study(StudySpec(ValueList("g", [0.0]), Paced(pauses_s=(0.02,))), Recording(),
                    progress=False)
    assert run.cost_per_point_s >= 0.02


@pytest.mark.parametrize("batch_size, last", [(None, 3), (1, 3), (1, 9), (None, 9)])
def test_a_stop_request_ends_the_study_after_the_point_under_way(tmp_path, batch_size, last):
    """SIGTERM while point ``last`` is evaluated (serially, in the measuring or in batches):
    that point is journaled, no later point is evaluated, the tables hold the finished points,
    and the study ends as stopped -- also when it was the study's last point (the request is
    read between points and after the last, rotor_avc.studies.interrupt)."""
    import os
    import signal

    class Stopping(Counting):
        def evaluate(self, context, point):
            if point.index == last:
                os.kill(os.getpid(), signal.SIGTERM)
            return super().evaluate(context, point)

    spec = StudySpec(ValueList("g", np.arange(10, dtype=float)), Stopping())
    with pytest.raises(KeyboardInterrupt):
        run_study(spec, SerialBackend(), out=tmp_path / "study", batch_size=batch_size,
                  progress=False)
    done = list(range(last + 1))
    assert spec.evaluator.seen == done
    journal = (tmp_path / "study" / "journal.csv").read_text().splitlines()
    assert sorted(int(line.split(",")[0]) for line in journal[2:]) == done
    assert len((tmp_path / "study" / "points.csv").read_text().splitlines()) == 1 + len(done)


def test_the_progress_shows_every_tenth_of_the_study(capsys):
    """On a stream that is no terminal, one line per tenth: 10 points in batches of one give
    lines at 1/10 ... 10/10, the last one full."""
    run_study(study(10), Recording(), batch_size=1, progress=True)
    lines = capsys.readouterr().err.splitlines()
    assert [line.split("] ")[1].split(" ")[0] for line in lines] == \
        [f"{k}/10" for k in range(1, 11)]
    assert lines[-1].startswith("[" + "#" * 30 + "] 10/10 points")
