"""A channel read chunk by chunk against the same channel held whole: the stamp statistics of
rotor_avc.analysis.stamp_stream equal resampling.stamp_quality (rate from the first 4096
intervals), the samples kept equal clean_stamps', a clock step across a chunk boundary is
found, and a bag's chunks (BagReader.series_chunks) are its series."""
import numpy as np
import pytest

from rotor_avc.analysis import resampling as R
from rotor_avc.analysis.stamp_stream import StampStream
from rotor_avc.bag import BagReader
from rotor_avc.bag.topics import Stream
from rotor_avc.bag.writer import BagWriter


def _channel(seed: int, n: int = 20000, period_s: float = 1e-3):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * period_s + rng.normal(0, 2e-5, n)
    keep = np.ones(n, bool)
    for start in rng.integers(0, n - 60, 8):                  # bursts of 5-40 dropped samples
        keep[start:start + rng.integers(5, 40)] = False
    keep &= rng.random(n) > 0.01
    t, y = t[keep], np.sin(2 * np.pi * 7.0 * t[keep])
    y[rng.integers(0, y.size, 5)] = np.nan
    return t, y


@pytest.mark.parametrize("chunk", [7, 500, 4096, 30000])
def test_chunks_give_the_statistics_and_samples_of_the_whole_channel(chunk):
    t, y = _channel(3)
    stream = StampStream("x")
    parts = [stream.add(t[i:i + chunk], y[i:i + chunk]) for i in range(0, t.size, chunk)]
    kept_t = np.concatenate([p[0] for p in parts])
    ok, excluded = R.usable_samples(y)
    whole_t, whole_y, fixed = R.clean_stamps(t[ok], y[ok])
    # a sample out of order across a chunk boundary is dropped (held whole: sorted in)
    assert whole_t.size - kept_t.size == stream.reordered - fixed >= 0
    assert np.all(np.diff(kept_t) > 0) and np.isin(kept_t, whole_t).all()
    q, ref = stream.quality(), R.stamp_quality("x", whole_t, fixed)
    assert stream.excluded == excluded == 5
    assert q.rate_hz == pytest.approx(ref.rate_hz, rel=2e-3)
    assert q.jitter_s == pytest.approx(ref.jitter_s, rel=0.05)
    assert abs(q.dropouts - ref.dropouts) <= whole_t.size - kept_t.size + 2
    assert q.longest_gap_s == pytest.approx(ref.longest_gap_s, rel=1e-6)


@pytest.mark.parametrize("at", [100, 999, 1000, 1001, 1990])
def test_a_clock_step_is_found_wherever_the_chunks_cut_it(at):
    n = 3000
    log = np.arange(n) * 1e-3
    stamps = log + 4e-4 + np.where(np.arange(n) >= at, 2.0, 0.0)
    stamps[500] += 0.5                                       # one late sample: not a step
    stream = StampStream("x")
    for i in range(0, n, 1000):
        stream.add(stamps[i:i + 1000], np.zeros(1000), log[i:i + 1000])
    stream.finish_clock()
    assert stream.clock_step is not None and stream.clock_step[0] == pytest.approx(log[at])
    assert stream.clock_step[1] == pytest.approx(2.0)
    assert R.clock_steps(stamps, log)[0] == pytest.approx(stream.clock_step)


def test_a_bags_chunks_are_its_series(tmp_path):
    n = 50000
    time_ns = np.arange(n, dtype=np.int64) * 1_000_000 + 7
    stream = Stream("/imu", "geometry_msgs/msg/AccelStamped", time_ns,
                    {"header": {"frame_id": "imu"}}, {"accel.linear.z": np.sin(np.arange(n) * 0.01),
                     "header.stamp.sec": time_ns // 1_000_000_000,
                     "header.stamp.nanosec": time_ns % 1_000_000_000})
    path = tmp_path / "imu.mcap"
    with BagWriter(path, None) as bag:
        bag.write_streams([stream])
    with BagReader(path) as bag:
        whole = bag.series("/imu")
        chunks = list(bag.series_chunks("/imu"))
    assert len(chunks) > 1
    np.testing.assert_array_equal(np.concatenate([c.time_ns for c in chunks]), whole.time_ns)
    for name in ("accel.linear.z", "header.stamp.nanosec"):
        np.testing.assert_array_equal(np.concatenate([c[name] for c in chunks]), whole[name])
