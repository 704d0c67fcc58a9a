"""A bag read in one streaming pass: the run source ``rotor-avc compare`` uses by default.

The same run as :func:`rotor_avc.compare.recorded_run.read_run` gives (scenario, sequence check,
topics and sample matching are shared with it), but read chunk by chunk through the message
indexes (:meth:`rotor_avc.bag.reader.BagReader.chunk_rows`), about :data:`BLOCK_S` seconds of
log time decoded at once per topic (fixed-size CDR rows, as this package's bags hold), and cut
into constant-speed dwells as they come; only the current dwell's last
:data:`~rotor_avc.compare.recorded_run.MAX_DWELL_SAMPLES` samples are kept. A run without dwells
(a run-up) is order-tracked block by block (:meth:`BagSource.blocks`,
:func:`rotor_avc.analysis.order_tracking.run_up_stream`), keeping one window. So the memory of a
comparison is bounded by one dwell's tail (or one run-up window) and one block, whatever the
recording's length.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..bag import BagError, BagReader
from ..bag.reader import TopicSeries
from ..bag.topics import labels_of
from .recorded_run import (MAX_DWELL_SAMPLES, dropped_note, matched, open_run, signals,
                           tail_dwell, test_source, too_short)

#: log time read and decoded at once (s)
BLOCK_S = 1.0
#: consecutive speeds differing by more than this (relative) start a new dwell
#: (rotor_avc.analysis.order_tracking.dwells)
REL_TOL = 1e-6


def _decoded(bag: BagReader, topic: str, times: np.ndarray, rows: np.ndarray) -> TopicSeries:
    """A block of one topic's fixed-size CDR rows as a TopicSeries (in log-time order)."""
    codec = bag.codec(topic)
    layout = codec.layout(rows[0].tobytes())
    if not layout.matches(rows):
        raise _not_streamable(bag, topic)
    order = np.argsort(times, kind="stable")
    return TopicSeries(topic, codec.type_name, times[order], layout.decode(rows[order]),
                       labels_of(codec.decode(rows[0].tobytes())))


def _not_streamable(bag: BagReader, topic: str) -> BagError:
    return BagError(bag.path, f"topic {topic}: messages without an index or of different "
                    "layouts; the streaming reader decodes indexed fixed-size messages",
                    fix="compare it with --in-memory")


def _blocks(bag: BagReader, topics: dict, progress=None):
    """key -> TopicSeries of every topic, for consecutive spans of about :data:`BLOCK_S` of
    log time (chunk by chunk, each chunk decompressed once; a span where a topic has no
    message is skipped). ``progress``: called ``(whole seconds of log time read, of the
    recording)`` after each chunk (None: quiet)."""
    if not bag.has_message_indexes:
        raise _not_streamable(bag, next(iter(topics.values())))
    keys = {topic: key for key, topic in topics.items()}
    pending = {topic: [] for topic in keys}
    span_start = None
    first_ns, last_ns = bag.time_range_ns
    seconds = max(1, math.ceil((last_ns - first_ns) * 1e-9))
    for later, chunk in bag.chunk_rows(list(keys)):
        if progress is not None:
            progress(seconds if later is None else min(seconds, (later - first_ns) // 10**9),
                     seconds)
        for topic, (times, rows) in chunk.items():
            if rows is None:
                raise _not_streamable(bag, topic)
            pending[topic].append((times, rows))
            first = int(times.min())
            span_start = first if span_start is None else min(span_start, first)
        if span_start is None or (later is not None and later - span_start < BLOCK_S * 1e9):
            continue
        cut = np.inf if later is None else later
        block, rest = {}, {}
        for topic, parts in pending.items():
            times = np.concatenate([t for t, _ in parts]) if parts else np.zeros(0, np.int64)
            rows = np.concatenate([r for _, r in parts]) if parts else None
            done = times < cut
            rest[topic] = [(times[~done], rows[~done])] if parts and (~done).any() else []
            if done.any():
                block[keys[topic]] = _decoded(bag, topic, times[done], rows[done])
        pending = rest
        span_start = min((int(t.min()) for p in rest.values() for t, _ in p), default=None)
        if len(block) == len(topics):
            yield block


class BagSource:
    """A bag as the comparison consumes it (the metadata and dwells of
    :class:`~rotor_avc.compare.recorded_run.RecordedRun`), streamed."""

    def __init__(self, path, progress=None):
        self.path = Path(path)
        self.progress = progress      # of each pass over the recording (:func:`_blocks`)
        with BagReader(self.path, require_config=True, require_messages=True,
                       integrity=True) as bag:
            self.opened = open_run(bag, self.path)
            first = next(_blocks(bag, self.opened.topics), None)
        if first is None:
            raise too_short(self.opened)
        common, pick, _ = matched(self.opened, first)
        channels, _ = signals(self.opened, first, common, pick)
        self.channel_names = list(channels)
        self.scenario, self.config = self.opened.scenario, self.opened.config
        self.namespace = self.opened.namespace.strip("/")
        self.test_source = test_source(self.opened)
        self.dropped = 0

    #: nothing is assumed of the package's own bags (their configuration is recorded)
    assumptions: dict = {}
    tracking = None
    interpolation = None                # recorded on the run's own grid
    sample_period_s = property(lambda self: self.scenario.sample_period_s)
    machine = property(lambda self: self.scenario.machine)
    has_test_force = property(lambda self: self.scenario.test_force is not None)

    @property
    def notes(self) -> list[str]:
        """The bag's notes (after a pass: with the samples dropped in it)."""
        return self.opened.notes + ([dropped_note(self.dropped)] if self.dropped else [])

    def blocks(self):
        """``(time_s, angle_rad, speed_rad_s, channels, test_force)`` per block, in order."""
        self.dropped, matched_samples = 0, 0
        with BagReader(self.path) as bag:
            for series in _blocks(bag, self.opened.topics, self.progress):
                common, pick, dropped = matched(self.opened, series)
                self.dropped += dropped
                matched_samples += common.size
                if common.size:
                    channels, test = signals(self.opened, series, common, pick)
                    yield (common * 1e-9, pick("joint", "position[0]"),
                           pick("joint", "velocity[0]"), channels, test)
        if matched_samples < 3:
            raise too_short(self.opened)

    def dwells(self):
        """The constant-speed dwells at positive speed, in time order, one at a time."""
        pieces, total, last = [], 0, None
        for block in self.blocks():
            w = block[2]
            prev = np.concatenate([[w[0] if last is None else last], w[:-1]])
            jumps = np.abs(w - prev) > REL_TOL * np.maximum(np.abs(w), 1e-3)
            for a, b in zip(*_runs(jumps, w.size)):
                if jumps[a] and pieces:
                    yield from _closed(pieces, total)
                    pieces, total = [], 0
                pieces.append(tuple(_cut(x, a, b) for x in block))
                total += b - a
                while (len(pieces) > 1
                       and sum(len(p[0]) for p in pieces[1:]) >= MAX_DWELL_SAMPLES):
                    pieces.pop(0)
            last = w[-1]
        if pieces:
            yield from _closed(pieces, total)


def _runs(jumps: np.ndarray, n: int):
    """Starts and ends of the ranges between jumps (a jump starts a range)."""
    starts = np.concatenate([[0], np.flatnonzero(jumps[1:]) + 1])
    return starts, np.concatenate([starts[1:], [n]])


def _cut(x, a, b):
    if x is None:
        return None
    if isinstance(x, dict):
        return {k: v[a:b] for k, v in x.items()}
    return x[a:b]


def _closed(pieces, total: int):
    """The finished dwell (if it has more than one sample at positive speed)."""
    if total < 2:
        return
    t, angle, speed = (np.concatenate([p[i] for p in pieces]) for i in range(3))
    channels = {k: np.concatenate([p[3][k] for p in pieces]) for k in pieces[0][3]}
    test = None if pieces[0][4] is None else np.concatenate([p[4] for p in pieces])
    dwell = tail_dwell(t, angle, speed, channels, test, total)
    if np.mean(dwell.speed_rad_s) > 0:
        yield dwell
