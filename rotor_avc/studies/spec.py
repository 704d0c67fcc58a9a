"""What a worker needs: a study's spec (point set and evaluator), the outcome of one point and
the evaluation of a batch of points (:mod:`rotor_avc.studies.engine` describes the evaluator)."""
from __future__ import annotations

from dataclasses import dataclass

from .interrupt import check as check_stop


@dataclass(frozen=True)
class Outcome:
    """The record of point ``index``, or ``error`` when its evaluation raised."""

    index: int
    record: dict | None
    error: str | None = None


@dataclass
class StudySpec:
    """What a worker needs to evaluate any point: the point set and the evaluator."""

    points: object
    evaluator: object


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
