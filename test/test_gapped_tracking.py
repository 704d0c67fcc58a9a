"""Order tracking, shaft and broadband estimates on gapped, jittered records (a real rig's drops
and bursts), each against an exact synthetic truth:

* a continuous angle over kept samples 20 ms apart at 97 Hz (more than half a revolution per
  gap) gives the exact speed and phasor (the least-squares fit at the samples' own angles),
  where unwrapping would drop revolutions;
* tacho pulses with bursts of missing pulses and bouncing duplicates count every revolution;
  an encoder angle across a 37-revolution gap keeps its turns;
* a run-up tracked block by block equals the one-block result for any block size;
* clock steps (+1 day, -2 s) are found, latency spikes are not;
* H1 over the Welch segments between a record's gaps equals the FIR system's own response.
"""
import numpy as np
import pytest
import scipy.signal

from rotor_avc.analysis import order_tracking as ot
from rotor_avc.analysis import resampling as R
from rotor_avc.analysis.frf_estimate import (contiguous_runs, estimate_frf_gapped,
                                             gapped_segment_length)
from rotor_avc.errors import ModelError

TWO_PI = 2 * np.pi


def _burst_mask(n, rng, bursts, lo, hi):
    keep = np.ones(n, bool)
    for _ in range(bursts):
        length = int(rng.integers(lo, hi + 1))
        start = int(rng.integers(0, n - length))
        keep[start:start + length] = False
    return keep


@pytest.mark.parametrize("speed_hz, seed", [(97.1, 0), (33.3, 1), (5.2, 2), (118.0, 3)])
def test_gaps_longer_than_half_a_revolution_keep_speed_and_phasor(speed_hz, seed):
    rng = np.random.default_rng(seed)
    fs = 1000.0
    t = np.arange(int(6 * fs)) / fs
    w = np.full(t.size, TWO_PI * speed_hz)
    theta = TWO_PI * speed_hz * t + 0.3
    Y = 0.7 * np.exp(1j * 1.1)
    y = np.real(Y * np.exp(1j * theta)) + 0.05
    keep = _burst_mask(t.size, rng, 40, 5, 40)            # bursts of 5-40 samples (5-40 ms)
    assert np.max(np.diff(t[keep])) * speed_hz > 0.5 or speed_hz < 20
    track = ot.stepped_speed(t[keep], theta[keep], w[keep], {"y": y[keep]})
    np.testing.assert_allclose(track.speed_hz, speed_hz, rtol=1e-9)
    np.testing.assert_allclose(track.phasors["y"], Y, rtol=1e-9)
    assert track.sigma["y"][0] < 1e-9                       # no residual: exact


def test_pulses_with_bursts_and_bounces_count_every_revolution():
    rng = np.random.default_rng(4)
    f = 40.0 + 2.0 * np.arange(0, 20, 1 / 40)[:-1] / 20    # slow ramp 40 -> 42 Hz
    pulses = np.concatenate([[0.0], np.cumsum(1 / f)])
    keep = _burst_mask(pulses.size, rng, 6, 5, 40)
    keep[[0, -1]] = True
    bounce = pulses[keep][rng.random(keep.sum()) < 0.02] + 150e-6
    seen = np.sort(np.concatenate([pulses[keep], bounce]))
    p, revs, report = R.clean_pulses(seen)
    np.testing.assert_array_equal(p, pulses[keep])
    assert report.duplicates == bounce.size
    assert revs.sum() == pulses.size - 1 and report.missing == int((~keep).sum())
    assert report.longest_gap_revolutions >= 5


def test_an_encoder_angle_keeps_its_turns_across_a_long_gap():
    fs, f0, rate = 2000.0, 60.0, 3.0                       # 60 Hz, +3 Hz/s
    t = np.arange(int(4 * fs)) / fs
    theta = TWO_PI * (f0 * t + 0.5 * rate * t ** 2)
    keep = np.ones(t.size, bool)
    keep[3000:4200] = False                                # 0.6 s: about 37 revolutions
    wrapped = np.angle(np.exp(1j * theta[keep]))
    counted = R.count_revolutions(t[keep], wrapped)
    np.testing.assert_allclose(counted - counted[0], theta[keep] - theta[keep][0], atol=1e-9)
    assert np.unwrap(wrapped)[-1] - np.unwrap(wrapped)[0] < theta[-1] - theta[0] - TWO_PI * 30


@pytest.mark.parametrize("block", [1, 997, 5000, 10 ** 6])
def test_a_run_up_tracked_block_by_block_equals_one_block(block):
    fs = 5000.0
    t = np.arange(int(8 * fs)) / fs
    w = TWO_PI * (5.0 + 10.0 * t)
    theta = np.cumsum(w) / fs
    y = np.real((1 + 0.1 * t) * np.exp(1j * theta)) + 0.3
    whole = ot.run_up_stream([(t, theta, w, {"y": y})], ["y"], revolutions=8)
    parts = ((t[i:i + block], theta[i:i + block], w[i:i + block], {"y": y[i:i + block]})
             for i in range(0, t.size, block))
    streamed = ot.run_up_stream(parts, ["y"], revolutions=8)
    np.testing.assert_array_equal(streamed.phasors["y"], whole.phasors["y"])
    np.testing.assert_array_equal(streamed.speed_rad_s, whole.speed_rad_s)
    # quasi-stationary truth: the envelope at the window centre
    np.testing.assert_allclose(np.abs(whole.phasors["y"]), 1 + 0.1 * whole.time_s, rtol=2e-3)


def test_clock_steps_are_found_and_latency_spikes_are_not():
    rng = np.random.default_rng(5)
    t = np.arange(5000) / 1000.0
    log = t + 400e-6 + rng.exponential(300e-6, t.size)
    log[[100, 2000, 2001]] += 0.3                          # a recorder stall of single samples
    assert R.clock_steps(t, log) == []
    stepped = t.copy()
    stepped[3000:] += 86400.0
    [(at, step)] = R.clock_steps(stepped, log)
    assert at == pytest.approx(log[3000]) and step == pytest.approx(86400.0, abs=1e-3)
    back = t.copy()
    back[1500:] -= 2.0
    assert [round(s, 2) for _, s in R.clock_steps(back, log)] == [-2.0]


def test_non_finite_and_overflowing_samples_are_counted():
    y = np.array([1.0, np.nan, 2.0, np.inf, 1.7e308, -3.0])
    ok, excluded = R.usable_samples(y)
    assert excluded == 3 and ok.tolist() == [True, False, True, False, False, True]


def test_h1_between_gaps_equals_the_systems_response():
    rng = np.random.default_rng(6)
    fs = 1000.0
    b, a = scipy.signal.butter(2, 80.0, fs=fs)
    x = rng.standard_normal(60000)
    y = scipy.signal.lfilter(b, a, x) + 0.01 * rng.standard_normal(x.size)
    keep = _burst_mask(x.size, rng, 30, 5, 40)
    t = np.arange(x.size)[keep] / fs
    runs = contiguous_runs(t, 1 / fs)
    nperseg = gapped_segment_length([b_ - a_ for a_, b_ in runs])
    est = estimate_frf_gapped(x[keep], y[keep][:, None], fs, runs, nperseg)
    _, h = scipy.signal.freqz(b, a, worN=est.freq_hz, fs=fs)
    band = (est.freq_hz > 5) & (est.freq_hz < 200)
    np.testing.assert_allclose(est.h1[band, 0], h[band], rtol=0.03, atol=0.01)
    assert est.averages >= 8 and len(runs) > 20
    # gaps that leave fewer than two whole segments: refused with the reason
    with pytest.raises(ModelError, match="Welch segments"):
        estimate_frf_gapped(x, y[:, None], fs, [(0, 100), (200, 300)], 256)


def test_a_long_tacho_gap_in_a_run_up_counts_its_revolutions_from_both_sides():
    """4 Hz/s through a 2 s burst of missing pulses: the local median ratio would miscount it;
    the speeds on both sides (trapezoid) count it exactly."""
    t = np.linspace(0.0, 8.0, 200001)
    theta = TWO_PI * (10.0 * t + 2.0 * t ** 2)
    pulses = np.interp(TWO_PI * np.arange(1, int(theta[-1] / TWO_PI)), theta, t)
    keep = (pulses < 3.0) | (pulses > 5.0)
    p, revs, report = R.clean_pulses(pulses[keep])
    assert revs.sum() == pulses.size - 1 and report.longest_gap_revolutions == int((~keep).sum()) + 1
