"""The sample-sequence check streams: it reads the log times chunk by chunk, so its memory does
not grow with the run (a 10x longer bag: about the same peak), and it gives the verdict of a
check holding every log time -- also when chunks overlap in time (one topic's chunks written
after another's, a topic's blocks written out of order), when a topic lost its tail, or every
message of a channel the bag declares, and for a file without message indexes."""
from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from mcap.writer import IndexType, Writer

from rotor_avc.bag import BagReader, BagWriter, topics as T, write_bag
from rotor_avc.bag.cdr import CdrCodec
from rotor_avc.bag.metadata import CONFIG_RECORD, encode_config
from rotor_avc.bag.msgdefs import full_text, known_specs
from rotor_avc.bag.sequence import RANGES_SHOWN, check_sequence
from rotor_avc.cli import main

RATE_HZ = 1000.0
CONFIG = {"machine": {"model": "sequence"}, "discretisation": {"sample_rate_hz": RATE_HZ}}
CLOCK, ACCEL, FORCE = "/clock", "/avc/foot/DL/acceleration", "/avc/foot/DL/actuator_force"


def write_samples(path, samples: dict[str, list[int]], chunk_size: int = 2048):
    """A bag whose topics hold the sample indices ``samples[topic]``, written topic after topic
    in the order given (so chunks overlap in time wherever that order is not the time order)."""
    with BagWriter(path, CONFIG, chunk_size=chunk_size) as w:
        for topic, ks in samples.items():
            w.add_topic(topic)
            for k in ks:
                w.write(topic, {}, int(round(k * 1e9 / RATE_HZ)))
    return path


def reference(path):
    """Every sampled topic's verdict from all its log times at once (the check in memory)."""
    period_ns = 1e9 / RATE_HZ
    with BagReader(path) as r:
        ks = {t: np.rint(np.array([m.time_ns for m in r.raw_messages(t)], np.int64)
                         / period_ns).astype(np.int64) if r.topics[t].count else
              np.zeros(0, np.int64) for t in r.topics}
    n = 1 + max(int(k.max()) for k in ks.values() if len(k))
    out = {}
    for t, k in ks.items():
        unique = np.unique(k)
        missing = np.setdiff1d(np.arange(n), unique)
        breaks = np.flatnonzero(np.diff(missing) > 1)
        starts = np.concatenate([[0], breaks + 1]) if len(missing) else []
        ends = np.concatenate([breaks, [len(missing) - 1]]) if len(missing) else []
        ranges = [(missing[a] / RATE_HZ, missing[b] / RATE_HZ) for a, b in zip(starts, ends)]
        out[t] = (len(missing), ranges[:RANGES_SHOWN], len(ranges), len(k) - len(unique))
    return n, out


def streamed(path):
    with BagReader(path) as r:
        report = check_sequence(r)
    gaps = {g.topic: (g.missing, [(pytest.approx(a), pytest.approx(b)) for a, b in g.ranges_s],
                      g.range_count, g.repeated) for g in report.gaps}
    return report, gaps


def overlapping_chunks(path) -> bool:
    """Does some chunk start before the chunk before it (in start order) ends?"""
    with BagReader(path) as r:
        spans = [(start, max(int(t.max()) for t in times.values()))
                 for start, times in r.chunk_log_times(list(r.topics)) if times]
    return any(start <= end for (_, end), (start, _) in zip(spans, spans[1:]))


def test_a_topic_that_lost_its_tail_or_every_message_is_missing(tmp_path):
    n = 3000
    path = write_samples(tmp_path / "tail.mcap", {CLOCK: range(n), ACCEL: range(n - 7),
                                                  FORCE: []})
    report, gaps = streamed(path)
    assert not report.ok and report.samples == n
    assert gaps == {ACCEL: (7, [(2.993, 2.999)], 1, 0), FORCE: (n, [(0.0, 2.999)], 1, 0)}
    assert f"{ACCEL}: 7 sample(s) missing at 2.9930-2.9990 s" in report.verdict()


def test_overlapping_chunks_give_the_verdict_of_all_log_times(tmp_path):
    """Each topic written whole after the other (every chunk of one overlaps the other's), and
    the clock in reversed blocks of 700 samples; gaps and repeats on chunk boundaries."""
    n = 6000
    clock = [k for b in reversed(range(0, n, 700)) for k in range(b, min(b + 700, n))]
    accel = [k for k in range(n) if not (1000 <= k < 1040 or k % 997 == 3)]
    accel += [1399, 1400, 5999]                                     # repeats, out of order
    force = [k for k in range(n - 300) if k != 2100]
    path = write_samples(tmp_path / "overlap.mcap", {ACCEL: accel, CLOCK: clock, FORCE: force})
    assert overlapping_chunks(path)
    n_ref, expected = reference(path)
    report, gaps = streamed(path)
    assert report.samples == n_ref == n
    assert gaps == {t: e for t, e in expected.items() if e[0]}
    assert report.repeated == {ACCEL: 3}
    assert gaps[ACCEL][2] > RANGES_SHOWN and "more range(s)" in report.verdict()
    assert gaps[FORCE][:3] == (301, [(2.1, 2.1), (5.7, 5.999)], 2)


def peak_bytes(fn) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_memory_does_not_grow_with_the_run(tmp_path):
    """Peak traced memory of the check on a 10x longer bag: about the same, not 10x."""
    peaks = []
    for seconds in (10, 100):
        t = np.arange(int(seconds * RATE_HZ)) / RATE_HZ
        path = write_bag(tmp_path / f"run{seconds}.mcap",
                         [T.clock(t), T.foot_acceleration("DL", t, np.zeros(t.size)),
                          T.actuator_force("DL", t, np.zeros(t.size))], CONFIG,
                         chunk_size=1 << 14)
        with BagReader(path) as r:
            r.config                                  # the record parsed outside the peak
            report = None

            def run(r=r):
                nonlocal report
                report = check_sequence(r)
            peaks.append(peak_bytes(run))
        assert report.ok and report.samples == t.size
    print("peak bytes (1x, 10x run):", peaks)
    assert peaks[1] < 2 * peaks[0], peaks


def test_chunks_without_message_indexes_are_read(tmp_path, capsys):
    """A writer that leaves out the message indexes (the `mcap` package's, so told): the check
    reads each chunk's records instead and finds the same gap; `bag info` shows no rate."""
    path = tmp_path / "unindexed.mcap"
    data = CdrCodec("rosgraph_msgs/msg/Clock", known_specs()).encode({})
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=4096, index_types=IndexType.ALL & ~IndexType.MESSAGE)
        w.start(profile="ros2", library="test")
        sid = w.register_schema("rosgraph_msgs/msg/Clock", "ros2msg",
                                full_text("rosgraph_msgs/msg/Clock").encode())
        cid = w.register_channel(CLOCK, "cdr", sid)
        for k in [k for k in range(3000) if not 700 <= k < 710]:
            w.add_message(cid, k * 1_000_000, data, k * 1_000_000)
        w.add_metadata(CONFIG_RECORD, encode_config(CONFIG))
        w.finish()
    with BagReader(path) as r:
        assert not r.has_message_indexes
        report = check_sequence(r)
    assert report.samples == 3000 and len(report.gaps) == 1
    assert report.gaps[0].describe() == f"{CLOCK}: 10 sample(s) missing at 0.7000-0.7090 s"
    assert main(["bag", "info", str(path)]) == 0
    line = next(s for s in capsys.readouterr().out.splitlines() if CLOCK in s)
    assert line.split()[-3:] == ["2990", "-", "Hz"]
