"""What a worker needs: a study's spec (point set and evaluator), the outcome of one point and
the evaluation of a batch of points (:mod:`rotor_avc.studies.engine` describes the evaluator).

:class:`PointSet` and :class:`Evaluator` are the two protocols a study is built of: the grids and
samples of :mod:`.points` and the Jacobian columns and starts of a calibration are point sets;
the gain, stability and robustness studies and a calibration's residual and fit are evaluators
(``test/test_seams.py`` checks each against its protocol)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from .interrupt import check as check_stop


@dataclass(frozen=True)
class Outcome:
    """The record of point ``index``, or ``error`` when its evaluation raised."""

    index: int
    record: dict | None
    error: str | None = None


@runtime_checkable
class PointSet(Protocol):
    """Numbered points: ``point(i)`` a :class:`rotor_avc.studies.points.Point`, a pure function
    of ``i``; ``describe()`` what identifies the set (for resuming)."""

    def __len__(self) -> int: ...

    def point(self, index: int): ...

    def describe(self) -> dict: ...


@runtime_checkable
class Evaluator(Protocol):
    """``prepare()`` the work shared by all points (once per worker); ``evaluate(context,
    point)`` a point's record; ``fields`` the record's columns (None: arrays, in memory);
    ``describe()`` what identifies the study."""

    fields: dict | None

    def prepare(self): ...

    def evaluate(self, context, point) -> dict: ...

    def describe(self) -> dict: ...


@dataclass
class StudySpec:
    """What a worker needs to evaluate any point: the point set and the evaluator."""

    points: PointSet
    evaluator: Evaluator


def describe_error(exc: BaseException) -> str:
    """One line: ``Type: message`` (newlines folded, so a journal line stays one line)."""
    return " ".join(f"{type(exc).__name__}: {exc}".split())


def evaluate_batch(spec: StudySpec, context, indices) -> list[Outcome]:
    """Evaluate points ``indices`` of ``spec``; a failing point gives an :class:`Outcome` with
    its error instead of a record."""
    out = []
    for index in indices:
        check_stop()                             # a stop asked for in this process
        try:
            out.append(Outcome(int(index), spec.evaluator.evaluate(context, spec.points.point(index))))
        except Exception as exc:     # noqa: BLE001 -- recorded with the point, the study goes on
            out.append(Outcome(int(index), None, describe_error(exc)))
    return out
