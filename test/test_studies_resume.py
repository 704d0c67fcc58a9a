"""Resuming a study computes exactly the missing points (rotor_avc.studies.engine, .output,
.journal), counted where the work happens: inside the evaluator.

The engine drops results of points it already has before it counts them (``StudyRun.computed``)
and before ``on_outcome``; a count taken there cannot tell a resume that evaluates only the
missing points from one that evaluates everything again. The evaluator here appends the index
of every point it evaluates to a log file (any process: the calibration points in this one,
the batches in the workers), so the log is the independent count. The journal is resumed from
a shuffled, non-prefix state: its lines out of order and a gap in the middle, as a study whose
workers finished out of order and was stopped would leave it (the journal is appended in any
order by design). The reference is an uninterrupted run of the same study: the resumed tables
must be byte-identical to it.
"""
import math
import os
from dataclasses import dataclass

import numpy as np
import pytest

from rotor_avc.studies.backends import ProcessBackend, SerialBackend
from rotor_avc.studies.engine import StudySpec, run_study
from rotor_avc.studies.points import ValueList

N = 24


@dataclass(frozen=True)
class CountingEvaluator:
    """A pure record of a point (``y = sin(3 g) g^2``, ``big = y > 0.5``), and the index of each
    evaluation appended to the file ``log``."""

    log: str
    fields = {"y": float, "big": bool}

    def prepare(self):
        return 3.0

    def evaluate(self, context, point):
        fd = os.open(self.log, os.O_WRONLY | os.O_APPEND | os.O_CREAT)
        try:
            os.write(fd, f"{point.index}\n".encode())
        finally:
            os.close(fd)
        g = point.values["g"]
        y = math.sin(context * g) * g * g
        return {"y": y, "big": y > 0.5}

    def describe(self):
        return {"evaluator": "counting", "record": "sin(3 g) g^2"}


def spec(log):
    return StudySpec(ValueList("g", np.linspace(0.1, 2.4, N)), CountingEvaluator(str(log)))


def evaluated(log) -> list[int]:
    return sorted(int(v) for v in log.read_text().split()) if log.exists() else []


@pytest.fixture
def whole(tmp_path):
    """An uninterrupted run: every point evaluated exactly once."""
    log = tmp_path / "whole.log"
    run = run_study(spec(log), SerialBackend(), out=tmp_path / "whole", progress=False)
    assert evaluated(log) == list(range(N)) and run.computed == N
    return run, tmp_path / "whole"


def shuffled_folder(whole_dir, folder, keep):
    """A results folder whose journal holds the points ``keep``, lines in a shuffled order."""
    folder.mkdir()
    (folder / "study.json").write_bytes((whole_dir / "study.json").read_bytes())
    lines = (whole_dir / "journal.csv").read_text().splitlines(keepends=True)
    header, rows = lines[:2], {int(r.split(",")[0]): r for r in lines[2:]}
    assert sorted(rows) == list(range(N))
    order = np.random.default_rng(11).permutation(sorted(keep)).tolist()
    assert order != sorted(order)                           # really out of order
    (folder / "journal.csv").write_text("".join(header + [rows[i] for i in order]))


# a gap in the middle (8..15), the first and the last point kept, a few single holes
KEEP = sorted(set(range(N)) - set(range(8, 16)) - {3, 19, 22})
MISSING = sorted(set(range(N)) - set(KEEP))


@pytest.mark.parametrize("backend, batch_size", [
    (SerialBackend(), None),              # the calibration points evaluated here, then batches
    (SerialBackend(), 2),
    (ProcessBackend(2), 1),               # batches in two worker processes
])
def test_resume_from_a_shuffled_journal_evaluates_exactly_the_missing_points(
        whole, tmp_path, backend, batch_size):
    ref, whole_dir = whole
    folder = tmp_path / "resumed"
    shuffled_folder(whole_dir, folder, KEEP)
    log = tmp_path / "resumed.log"
    seen = []
    run = run_study(spec(log), backend, out=folder, batch_size=batch_size, progress=False,
                    on_outcome=seen.append)
    assert evaluated(log) == MISSING                        # each missing point once, no other
    assert run.computed == len(MISSING) and sorted(o.index for o in seen) == MISSING
    assert run.outcomes == ref.outcomes
    for name in ("points.csv", "points.npz"):
        assert (folder / name).read_bytes() == (whole_dir / name).read_bytes()
    rows = (folder / "journal.csv").read_text().splitlines()[2:]
    assert sorted(int(r.split(",")[0]) for r in rows) == list(range(N))


def test_a_complete_shuffled_journal_evaluates_nothing(whole, tmp_path):
    ref, whole_dir = whole
    folder = tmp_path / "complete"
    shuffled_folder(whole_dir, folder, range(N))
    log = tmp_path / "complete.log"
    run = run_study(spec(log), SerialBackend(), out=folder, progress=False)
    assert evaluated(log) == [] and run.computed == 0 and run.outcomes == ref.outcomes
    assert run.cost_per_point_s is None and run.batch_size == 1   # nothing measured or sent
    assert (folder / "points.csv").read_bytes() == (whole_dir / "points.csv").read_bytes()


def test_a_journal_without_its_first_points_resumes_them(whole, tmp_path):
    """Not a prefix at all: only the last half journaled (the first points are the ones the
    engine evaluates in this process to measure the cost)."""
    ref, whole_dir = whole
    folder = tmp_path / "tail"
    shuffled_folder(whole_dir, folder, range(N // 2, N))
    log = tmp_path / "tail.log"
    run = run_study(spec(log), SerialBackend(), out=folder, progress=False)
    assert evaluated(log) == list(range(N // 2)) and run.outcomes == ref.outcomes
