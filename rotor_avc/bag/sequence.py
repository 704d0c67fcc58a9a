"""Is every sample of the run in the bag? Checked before a bag is compared or replayed.

A run of the plant publishes one message per sample ``t_k = k T`` on each of its *sampled
topics* -- the foot measurements, ``rotor/joint_state``, ``/clock``, ``plant/observables``,
``plant/test_signal`` -- and each controller, the harmonic controller and the balancer answer
every sample (``foot/<id>/actuator_force``, ``harmonic/forces``, ``balancer/command``), stamped
``t_k``; the bag logs every
message at its stamp. So, per sampled topic, the log times must be exactly ``0, T, ..., (n-1) T``
(a sample published twice, as the lockstep plant resends an unanswered one, is counted as
repeated, not as an error), every sampled topic must hold the same samples, and the messages
recorded must equal those the publishers report as published (the bag's ``rotor_avc_counts``
record, rotor_avc.nodes.recorder). :func:`check_sequence` returns one :class:`SequenceReport`;
``ok`` is False when any sample is missing somewhere, and :meth:`SequenceReport.verdict` says
which topic lacks how many samples over which time ranges. A run that is complete but shorter
than its scenario (the plant stopped early on purpose, or the recording was cut at a sample) is
reported as a note.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import RotorAvcError
from .reader import BagReader
from .topics import SAMPLED

#: at most this many missing ranges are listed per topic
RANGES_SHOWN = 5
#: exit status of a command refusing a bag with missing samples (0 pass, 1 fail, 2 unreadable)
EXIT_INCOMPLETE = 3


class IncompleteRecordingError(RotorAvcError):
    """A bag lacks samples of its run: one verdict naming the topics, the number of missing
    samples and the time ranges (exit status EXIT_INCOMPLETE)."""

    exit_status = EXIT_INCOMPLETE

    def __init__(self, path, report: "SequenceReport"):
        self.report = report
        super().__init__(f"{path}: the recording is incomplete -- samples are missing, so no "
                         "comparison or replay of it can be trusted:\n  "
                         + report.verdict().replace("\n", "\n  ")
                         + "\nfix: record the run again (the recorder's log and the bag's "
                           "counts say where messages were lost)")


@dataclass
class TopicGaps:
    """The samples one topic lacks."""

    topic: str
    missing: int
    ranges_s: list[tuple[float, float]]
    repeated: int = 0

    def describe(self) -> str:
        ranges = ", ".join(f"{a:.4f}-{b:.4f} s" if b > a else f"{a:.4f} s"
                           for a, b in self.ranges_s[:RANGES_SHOWN])
        more = len(self.ranges_s) - RANGES_SHOWN
        return (f"{self.topic}: {self.missing} sample(s) missing at {ranges}"
                + (f" and {more} more range(s)" if more > 0 else ""))


@dataclass
class SequenceReport:
    """The sample sequence of a bag's sampled topics."""

    sample_period_s: float
    samples: int                                  # the run's samples found on any topic
    expected: int                                 # the scenario's samples
    gaps: list[TopicGaps] = field(default_factory=list)
    unrecorded: dict[str, tuple[int, int]] = field(default_factory=dict)  # published, recorded
    lost: dict[str, int] = field(default_factory=dict)
    repeated: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not (self.gaps or self.unrecorded or self.lost)

    def verdict(self) -> str:
        """One line per problem (empty when ok)."""
        lines = [g.describe() for g in self.gaps]
        lines += [f"{t}: {rec} of {pub} published messages recorded ({pub - rec} missing)"
                  for t, (pub, rec) in sorted(self.unrecorded.items())]
        lines += [f"{t}: the recording reports {n} message(s) lost"
                  for t, n in sorted(self.lost.items())]
        return "\n".join(lines)


def check_sequence(reader: BagReader, expected_samples: int = 0) -> SequenceReport:
    """The sample sequence of the bag ``reader`` (see the module docstring);
    ``expected_samples``: the scenario's samples, for the note on an incomplete run."""
    rate_hz = (reader.config.get("discretisation") or {}).get("sample_rate_hz")
    if not isinstance(rate_hz, (int, float)) or not rate_hz > 0:
        report = SequenceReport(0.0, 0, int(expected_samples))
        report.notes.append("the run configuration has no discretisation.sample_rate_hz: only "
                            "the published/recorded counts are checked")
        _check_counts(reader, report)
        return report
    period_s = 1.0 / float(rate_hz)
    period_ns = period_s * 1e9
    expected = int(expected_samples)
    topics = [t for t, info in reader.topics.items() if SAMPLED.match(t) and info.count]
    indices = {}
    for t in topics:
        k = np.rint(reader.log_times(t) / period_ns).astype(np.int64)
        indices[t] = k
    n = 1 + max((int(k[-1]) for k in indices.values() if len(k)), default=-1)
    report = SequenceReport(period_s, n, expected)
    for t, k in indices.items():
        unique = np.unique(k)
        if len(unique) < len(k):
            report.repeated[t] = len(k) - len(unique)
        missing = np.setdiff1d(np.arange(n), unique, assume_unique=True)
        if len(missing):
            report.gaps.append(TopicGaps(t, len(missing), _ranges(missing, period_s),
                                         report.repeated.get(t, 0)))
    _check_counts(reader, report)
    if expected and n < expected and report.ok:
        report.notes.append(f"incomplete run: {n} of the scenario's {expected} samples "
                            f"({n * period_s:.4g} of {expected * period_s:.4g} s) were recorded")
    return report


def _check_counts(reader: BagReader, report: SequenceReport) -> None:
    """Published against recorded, and reported losses, from the bag's counts record."""
    counts = reader.counts or {}
    for t, c in counts.items():
        if c["published"] is not None and c["recorded"] < c["published"]:
            report.unrecorded[t] = (c["published"], c["recorded"])
        if c["lost"]:
            report.lost[t] = c["lost"]
    if not counts:
        report.notes.append("the bag has no published/recorded counts: only the sample "
                            "sequence is checked")


def require_complete(reader: BagReader, expected_samples: int = 0) -> SequenceReport:
    """:func:`check_sequence`, raising :class:`IncompleteRecordingError` unless it is ok."""
    report = check_sequence(reader, expected_samples)
    if not report.ok:
        raise IncompleteRecordingError(reader.path, report)
    return report


def _ranges(missing: np.ndarray, period_s: float) -> list[tuple[float, float]]:
    """Consecutive runs of missing sample indices as (first, last) times in s."""
    breaks = np.flatnonzero(np.diff(missing) > 1)
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks, [len(missing) - 1]])
    return [(missing[a] * period_s, missing[b] * period_s) for a, b in zip(starts, ends)]
