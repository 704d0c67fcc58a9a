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
which topic lacks how many samples over which time ranges -- also the last samples, or every
one, of a sampled topic the bag declares. A run that is complete but shorter than its scenario
(the plant stopped early on purpose, or the recording was cut at a sample) is reported as a note.
The check streams (:func:`check_sequence`): its memory does not grow with the run.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import RotorAvcError
from .reader import BagReader
from .topics import SAMPLED

#: at most this many missing ranges are kept and listed per topic (the rest are counted)
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
    """The samples one topic lacks: ``ranges_s`` the first :data:`RANGES_SHOWN` missing
    ranges (first, last sample time), ``range_count`` how many there are in all."""

    topic: str
    missing: int
    ranges_s: list[tuple[float, float]]
    repeated: int
    range_count: int

    def describe(self) -> str:
        ranges = ", ".join(f"{a:.4f}-{b:.4f} s" if b > a else f"{a:.4f} s"
                           for a, b in self.ranges_s[:RANGES_SHOWN])
        more = max(self.range_count, len(self.ranges_s)) - RANGES_SHOWN
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
    ``expected_samples``: the scenario's samples, for the note on an incomplete run.

    The log times are read chunk by chunk from the message indexes (``chunk_log_times``) and
    folded into one :class:`_Sequence` per topic, so memory does not grow with the run: chunks
    come in the order of their start times, and a sample index is settled only once no later
    chunk can hold a smaller one (chunks may overlap in time); the rest waits in a buffer
    bounded by that overlap."""
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
    seqs = {t: _Sequence() for t in reader.topics if SAMPLED.match(t)}
    chunks = reader.chunk_log_times(list(seqs))
    chunk = next(chunks, None)
    while chunk is not None:
        later = next(chunks, None)
        settled = None if later is None else int(np.rint(later[0] / period_ns))
        for t, times in chunk[1].items():
            seqs[t].pending.append(np.rint(times / period_ns).astype(np.int64))
        for seq in seqs.values():
            seq.settle(settled)
        chunk = later
    n = 1 + max((seq.last for seq in seqs.values()), default=-1)
    report = SequenceReport(period_s, n, expected)
    for t, seq in seqs.items():
        seq.finish(n)
        if seq.repeated:
            report.repeated[t] = seq.repeated
        if seq.missing:
            report.gaps.append(TopicGaps(t, seq.missing, [(a * period_s, b * period_s)
                                                          for a, b in seq.ranges],
                                         seq.repeated, seq.range_count))
    _check_counts(reader, report)
    if expected and n < expected and report.ok:
        report.notes.append(f"incomplete run: {n} of the scenario's {expected} samples "
                            f"({n * period_s:.4g} of {expected * period_s:.4g} s) were recorded")
    return report


class _Sequence:
    """One topic's sample indices, settled in ascending order: the last index settled, the
    missing samples (count, the first :data:`RANGES_SHOWN` ranges, the number of ranges) and
    the repeats; ``pending`` holds indices not yet settled."""

    def __init__(self):
        self.last = -1
        self.missing = self.repeated = self.range_count = 0
        self.ranges: list[tuple[int, int]] = []
        self.pending: list[np.ndarray] = []

    def settle(self, below: int | None) -> None:
        """Settle every pending index below ``below`` (all of them for None)."""
        if not self.pending:
            return
        k = np.sort(np.concatenate(self.pending))
        cut = len(k) if below is None else int(np.searchsorted(k, below))
        self.pending = [k[cut:]] if cut < len(k) else []
        k = k[:cut]
        if not len(k):
            return
        prev = np.concatenate([[self.last], k[:-1]])
        self.repeated += int(np.count_nonzero(k == prev))
        self._gaps(np.maximum(prev + 1, 0), k - 1)
        self.last = max(self.last, int(k[-1]))

    def finish(self, n: int) -> None:
        """Once everything is settled: the samples after the last one up to ``n - 1`` are
        missing (a topic that lost its tail, or every message)."""
        self._gaps(np.array([self.last + 1]), np.array([n - 1]))

    def _gaps(self, first: np.ndarray, last: np.ndarray) -> None:
        """Count the missing ranges ``first[i]..last[i]`` (inclusive; empty where last < first)."""
        gap = last >= first
        if not np.any(gap):
            return
        first, last = first[gap], last[gap]
        self.missing += int(np.sum(last - first + 1))
        self.range_count += len(first)
        keep = RANGES_SHOWN - len(self.ranges)
        self.ranges += [(int(a), int(b)) for a, b in zip(first[:keep], last[:keep])]


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
