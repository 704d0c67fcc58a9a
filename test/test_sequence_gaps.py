"""The sample-sequence check (rotor_avc.bag.sequence) on log times written by hand: a reader
stand-in gives the chunks' log times, so every missing sample, range, repeat and count below
is the hand count of the indices put in -- a topic that lost its last k samples, a topic with
no message, gaps of one sample, more ranges than are listed, counts that disagree."""
from types import SimpleNamespace

import numpy as np
import pytest

from rotor_avc.bag.sequence import (RANGES_SHOWN, IncompleteRecordingError, TopicGaps, _Sequence,
                                    check_sequence, require_complete)

RATE_HZ = 1000.0
A, B = "/clock", "rotor/joint_state"


def reader(samples: dict, chunk: int = 0, counts=None, rate_hz=RATE_HZ):
    """A bag of the sampled topics ``samples`` (topic -> sample indices, logged at k / rate),
    in chunks of ``chunk`` consecutive samples (0: one chunk)."""
    times = {t: np.asarray(k, np.int64) * int(1e9 / RATE_HZ) for t, k in samples.items()}
    last = max((int(k.max()) for k in times.values() if k.size), default=0)
    step = chunk * int(1e9 / RATE_HZ) if chunk else last + 1

    def chunks(topics):
        for start in range(0, last + 1, step):
            yield start, {t: v[(v >= start) & (v < start + step)] for t, v in times.items()
                          if t in topics and np.any((v >= start) & (v < start + step))}
    config = {"discretisation": {"sample_rate_hz": rate_hz}} if rate_hz is not None else {}
    return SimpleNamespace(config=config, topics=dict.fromkeys(samples), path="run.mcap",
                           counts=counts or {}, chunk_log_times=chunks)


def test_a_topic_that_lost_its_last_k_samples_is_incomplete():
    full = np.arange(100)
    for k in (1, 7):
        report = check_sequence(reader({A: full, B: full[:-k]}), expected_samples=100)
        assert not report.ok and report.samples == 100
        (gap,) = report.gaps
        assert (gap.topic, gap.missing, gap.range_count) == (B, k, 1)
        np.testing.assert_allclose(gap.ranges_s, [((100 - k) / RATE_HZ, 99 / RATE_HZ)], rtol=1e-12)
        with pytest.raises(IncompleteRecordingError, match=rf"{B}: {k} sample\(s\) missing"):
            require_complete(reader({A: full, B: full[:-k]}), 100)


def test_a_complete_but_short_run_is_a_note_and_a_complete_one_is_silent():
    report = require_complete(reader({A: np.arange(80), B: np.arange(80)}), 100)
    assert report.ok and report.notes == [
        "incomplete run: 80 of the scenario's 100 samples (0.08 of 0.1 s) were recorded",
        "the bag has no published/recorded counts: only the sample sequence is checked"][::-1]
    counts = {A: {"published": 100, "recorded": 100, "lost": 0}}
    full = check_sequence(reader({A: np.arange(100)}, counts=counts), 100)
    assert full.ok and full.notes == [] and full.verdict() == ""


def test_a_declared_topic_without_messages_lacks_every_sample():
    report = check_sequence(reader({A: np.arange(50), B: np.array([], np.int64)}))
    (gap,) = report.gaps
    assert (gap.topic, gap.missing, gap.ranges_s) == (B, 50, [(0.0, pytest.approx(0.049))])


@pytest.mark.parametrize("chunk", [0, 4, 7])
def test_gaps_repeats_and_ranges_by_hand(chunk):
    k = np.array([0, 1, 2, 2, 5, 6, 6, 6, 9, 11])       # missing 3-4, 7-8, 10; 3 repeats
    report = check_sequence(reader({A: np.arange(14), B: k}, chunk=chunk))
    (gap,) = report.gaps
    assert (gap.missing, gap.range_count, gap.repeated) == (7, 4, 3)   # 12, 13: the tail
    np.testing.assert_allclose(gap.ranges_s, [(0.003, 0.004), (0.007, 0.008), (0.010, 0.010),
                                              (0.012, 0.013)], rtol=1e-12)
    assert report.repeated == {B: 3}
    assert gap.describe() == (f"{B}: 7 sample(s) missing at 0.0030-0.0040 s, 0.0070-0.0080 s, "
                              "0.0100 s, 0.0120-0.0130 s")


def test_only_the_first_ranges_are_listed_and_the_rest_counted():
    seq = _Sequence()
    seq.pending = [np.array([0, 2, 4])]                 # two gaps in the first settle
    seq.settle(None)
    seq.pending = [np.arange(6, 14, 2)]                 # four more in the second
    seq.settle(None)
    seq.finish(15)                                      # and the tail 13-14
    assert (seq.missing, seq.range_count) == (8, 7)
    assert seq.ranges == [(1, 1), (3, 3), (5, 5), (7, 7), (9, 9)]
    assert len(seq.ranges) == RANGES_SHOWN
    gaps = TopicGaps(B, seq.missing, [(a * 0.001, b * 0.001) for a, b in seq.ranges], 0,
                     seq.range_count)
    assert gaps.describe() == (f"{B}: 8 sample(s) missing at 0.0010 s, 0.0030 s, 0.0050 s, "
                               "0.0070 s, 0.0090 s and 2 more range(s)")


def test_settling_waits_for_a_later_chunk_that_may_hold_a_smaller_index():
    seq = _Sequence()
    seq.pending = [np.array([0, 1, 4])]
    seq.settle(3)                                       # 4 waits: a later chunk may hold 2, 3
    assert (seq.last, seq.missing) == (1, 0)
    seq.pending.append(np.array([3, 2]))
    seq.settle(None)
    seq.finish(5)
    assert (seq.last, seq.missing, seq.repeated, seq.ranges) == (4, 0, 0, [])


def test_counts_published_recorded_and_lost():
    counts = {A: {"published": 100, "recorded": 98, "lost": 0},
              B: {"published": None, "recorded": 100, "lost": 2}}
    report = check_sequence(reader({A: np.arange(100), B: np.arange(100)}, counts=counts))
    assert not report.ok and report.gaps == []
    assert report.unrecorded == {A: (100, 98)} and report.lost == {B: 2}
    assert report.verdict() == (f"{A}: 98 of 100 published messages recorded (2 missing)\n"
                                f"{B}: the recording reports 2 message(s) lost")


def test_without_a_sample_rate_only_the_counts_are_checked():
    counts = {A: {"published": 10, "recorded": 9, "lost": 0}}
    report = check_sequence(reader({A: np.arange(3)}, counts=counts, rate_hz=None), 10)
    assert (report.sample_period_s, report.samples, report.expected) == (0.0, 0, 10)
    assert report.notes == ["the run configuration has no discretisation.sample_rate_hz: only "
                            "the published/recorded counts are checked"]
    assert not report.ok and report.unrecorded == {A: (10, 9)}
    assert check_sequence(reader({A: np.arange(3)}, rate_hz=0.0)).notes[0].startswith(
        "the run configuration has no discretisation.sample_rate_hz")


def test_a_bag_without_sampled_topics_has_no_samples():
    report = check_sequence(reader({"/rosout": np.arange(5)}), 100)
    assert (report.samples, report.gaps, report.ok) == (0, [], True)
    assert report.notes[-1] == ("incomplete run: 0 of the scenario's 100 samples (0 of 0.1 s) "
                                "were recorded")
    # without the scenario's sample count (0: unknown) the run's length is not judged
    unknown = check_sequence(reader({"/rosout": np.arange(5)}))
    assert (unknown.samples, unknown.expected) == (0, 0)
    assert not any(n.startswith("incomplete run") for n in unknown.notes)


def test_a_topic_that_lost_its_first_samples_and_exactly_the_listed_ranges():
    report = check_sequence(reader({A: np.arange(50), B: np.arange(3, 50)}))
    (gap,) = report.gaps
    assert (gap.missing, gap.ranges_s) == (3, [(0.0, 0.002)])
    seq = _Sequence()
    seq.pending = [np.arange(0, 2 * RANGES_SHOWN + 1, 2)]      # exactly RANGES_SHOWN gaps
    seq.settle(None)
    gaps = TopicGaps(B, seq.missing, [(a * 0.001, b * 0.001) for a, b in seq.ranges], 0,
                     seq.range_count)
    assert gaps.describe() == (f"{B}: 5 sample(s) missing at 0.0010 s, 0.0030 s, 0.0050 s, "
                               "0.0070 s, 0.0090 s")            # no "and 0 more"
    seq.finish(2 * RANGES_SHOWN + 3)                            # one range more: the tail
    gaps = TopicGaps(B, seq.missing, [(a * 0.001, b * 0.001) for a, b in seq.ranges], 0,
                     seq.range_count)
    assert gaps.describe().endswith("0.0090 s and 1 more range(s)")
