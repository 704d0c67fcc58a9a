"""The parts of a mapped recording's comparison (rotor_avc.compare.mapped_run) on small hand-made
inputs, each against a hand computation: the order-tracking windows of a run-up and the ones a
tacho gap or the channels' span leave out, the resampling grid and its memory check, the noise
and broadband notes."""
from types import SimpleNamespace

import numpy as np
import pytest

from rotor_avc.analysis import resampling as R
from rotor_avc.analysis.frf_estimate import FrfEstimate
from rotor_avc.compare import mapped_run
from rotor_avc.compare.recording_map import ShaftMap, SignalMap
from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.resources import ResourceError


def runup_pulses(revolutions: int = 40) -> np.ndarray:
    """Pulse times of a run-up from 10 Hz at 10 Hz/s: revolutions ``10 t + 5 t^2 = k``."""
    k = np.arange(revolutions + 1)
    return (-10.0 + np.sqrt(100.0 + 20.0 * k)) / 10.0


def test_runup_windows_are_whole_revolutions_and_a_tacho_gap_leaves_out_the_ones_it_overlaps():
    p = runup_pulses()
    # pulses 22-24 lost: one interval of 4 revolutions from pulse 21 to pulse 25
    shaft = R.shaft_from_pulses(np.delete(p, [22, 23, 24]), p)
    assert not shaft.dwells and shaft.pulse_gaps == [(p[21], p[25], 4)]
    kept, gapped, method, settings = mapped_run.shaft_windows(shaft, 4)
    assert method.startswith("run-up") and settings["revolutions_per_window"] == 4
    # 40 revolutions: 10 windows of 4, [p0, p4] ... [p36, p40]; the gap (p21, p25) overlaps
    # the 6th and the 7th, each missing 3 pulses
    expected = [(p[4 * i], p[4 * i + 4], 4) for i in range(10) if i not in (5, 6)]
    assert len(kept) == 8
    np.testing.assert_allclose(np.array(kept), np.array(expected), rtol=0, atol=1e-12)
    assert [g[2] for g in gapped] == [3, 3]
    assert gapped[0][0] == pytest.approx(p[20], abs=1e-12)
    assert gapped[1][1] == pytest.approx(p[28], abs=1e-12)
    # inside the gap the angle is interpolated: the shared end lies between pulses 21 and 25
    assert p[21] < gapped[0][1] == gapped[1][0] < p[25]
    notes = mapped_run.gap_notes(gapped)
    assert len(notes) == 2 and "the tacho missed 3 pulses" in notes[0]


def test_dwell_windows_cover_the_second_half_of_each_dwell_as_reported():
    speed_hz = 20.0
    p = np.arange(41) / speed_hz                      # 40 revolutions at 20 Hz: one dwell
    shaft = R.shaft_from_pulses(p, p)
    windows, gapped, method, settings = mapped_run.shaft_windows(shaft, 4)
    assert method == "stepped-speed dwells" and gapped == []
    # the whole revolutions ending at the dwell's end after its first half: 20 of them
    (t0, t1, n), = windows
    assert (n, t1) == (20, p[-1]) and t0 == pytest.approx(1.0, abs=1e-12)
    first = settings["settle_fraction"] * (p[-1] - p[0])
    assert first <= t0 + 1e-12 and t0 - first < 1.0 / speed_hz
    assert n >= settings["min_revolutions"]


@pytest.mark.parametrize("start_s, stop_s, inside", [
    (0.0, 3.0, [0, 1, 2]),             # windows ending at the stop and starting at the start
    (0.5, 3.0, [1, 2]),
    (0.0, 2.5, [0, 1]),
    (1.0, 2.0, [1]),
    (1.5, 1.8, [])])
def test_within_channels_keeps_the_windows_the_channels_cover(start_s, stop_s, inside):
    windows = [(0.0, 1.0, 4), (1.0, 2.0, 4), (2.0, 3.0, 4)]
    gapped = [(0.0, 1.0, 3), (1.0, 2.0, 3), (2.0, 3.0, 3)]
    kept, left = mapped_run.within_channels(windows, gapped, start_s, stop_s)
    assert kept == [windows[i] for i in inside] and left == [gapped[i] for i in inside]


def test_run_up_tracking_fits_the_covered_windows_and_counts_the_ones_left_out():
    p = runup_pulses()
    shaft = R.shaft_from_pulses(np.delete(p, [22, 23, 24]), p)
    amp, phase = 0.3, 0.7                             # y = amp cos(theta + phase): 1x phasor
    # the channel: 1 kHz from just before pulse 4 to exactly pulse 36 (a window's end), with a
    # dropout over the window [p8, p12]
    t = np.r_[np.arange(p[4] - 0.0137, p[36], 1e-3), p[36]]
    t = t[(t < p[8] + 0.002) | (t > p[12] - 0.002)]
    # at the angle the pulses give (linear between them): the fit is exact
    y = amp * np.cos(shaft.knots.angle(t) + phase)
    run = SimpleNamespace(notes=[])
    track, method, settings = mapped_run.ShaftTracking(run, shaft, {"acc": (t, y)})(
        ["acc"], 1.0, 4)
    # covered: [p4, p8] ... [p32, p36]: 8 windows; the tacho gap takes 2, the dropout 1
    assert method.startswith("run-up") and track.speed_hz.size == 5
    np.testing.assert_allclose(track.time_s, [0.5 * (p[i] + p[i + 4]) for i in (4, 12, 16, 28, 32)],
                               atol=1e-12)
    np.testing.assert_allclose(track.phasors["acc"], amp * np.exp(1j * phase), atol=1e-12)
    assert settings["windows_left_out"] == 3
    assert sum("tacho missed 3 pulses" in n for n in run.notes) == 2
    assert sum("fewer than 4 samples per revolution" in n for n in run.notes) == 1


def _clean(stamps):
    return (stamps, np.zeros(stamps.size), R.stamp_quality("x", stamps))


def test_the_grid_starts_at_the_fastest_channels_first_stamp_inside_every_channel():
    fast = 0.0003 + 1e-3 * np.arange(1000)            # 1 kHz, 0.0003 ... 0.9993 s
    slow = 0.05 + 5e-3 * np.arange(171)               # 200 Hz, 0.05 ... 0.90 s
    grid = mapped_run._grid({"a": _clean(fast), "b": _clean(slow)}, 1e-3)
    # from the first fast stamp at or after 0.05 s (0.0503) in 1 ms steps up to 0.90 s
    assert grid.size == 850
    np.testing.assert_allclose(grid, 0.0503 + 1e-3 * np.arange(850), rtol=0, atol=1e-12)
    assert grid[-1] <= slow[-1]


def test_the_grid_memory_is_checked_for_the_grid_it_builds(monkeypatch):
    fast = 0.0003 + 1e-3 * np.arange(1000)
    slow = 0.05 + 5e-3 * np.arange(171)
    clean = {"a": _clean(fast), "b": _clean(slow)}
    # below the bytes of the grid and its two channels alone: refused, naming the grid's size
    held = 850 * 8 * 3
    monkeypatch.setenv("ROTOR_AVC_MAX_MEMORY_GB", repr(0.9 * held / 2**30))
    with pytest.raises(ResourceError, match=r"a (850|851)-point resampling grid \(0\.85 s at "
                                            r"1000 Hz, 2 channels\)"):
        mapped_run._grid(clean, 1e-3)
    monkeypatch.setenv("ROTOR_AVC_MAX_MEMORY_GB", repr(1e3 * held / 2**30))
    assert mapped_run._grid(clean, 1e-3).size == 850
    with pytest.raises(ConfigError, match="do not overlap"):
        mapped_run._grid({"a": _clean(fast), "b": (np.array([1.5, 1.6, 1.7]), np.zeros(3),
                                                   R.stamp_quality("b", [1.5, 1.6, 1.7]))}, 1e-3)


def test_noise_notes_rate_the_relative_error_of_each_dwells_1x():
    # |Y| = 10 with sigma 0.05: eps 0.005, 2 sigma 20 log10(1.01) = 0.086 dB (decidable);
    # |Y| = 1 with sigma 0.05: 20 log10(1.1) = 0.83 dB, above 0.5 dB
    track = SimpleNamespace(speed_hz=np.array([20.0, 30.0]),
                            phasors={"acc": np.array([10.0, 1.0j])},
                            sigma={"acc": np.array([0.05, 0.05])})
    notes = mapped_run.noise_notes(track, "stepped-speed dwells")
    assert notes[0] == ("1x of acc at 30 Hz: noise allows +-0.83 dB (2 sigma), too poor for a "
                        "0.5 dB verdict")
    assert notes[1].endswith("largest +-0.83 dB (acc at 30 Hz)") and len(notes) == 2
    assert mapped_run.noise_notes(track, "run-up windows (quasi-stationary)") == []


def test_band_notes_count_the_bins_inside_two_sigma_of_the_model():
    freq = np.arange(10.0, 20.0)
    coh = np.full(10, 0.9)
    coh[:3] = 0.99
    averages = 8
    # eps = sqrt(1 - g2) / (|g| sqrt(2 n)) (Bendat & Piersol eq. 9.73)
    eps = np.sqrt(1 - coh) / (np.sqrt(coh) * 4.0)
    model = np.full(10, 2.0)
    # |H1| = model / (1 - k eps) is k eps |H1| from the model: k = 1 in 6 bins, k = 3 in 4
    k = np.array([1, 3, 1, 3, 1, 3, 1, 3, 1, 1], float)
    h1 = model / (1 - k * eps)
    est = FrfEstimate(freq, h1[:, None], h1[:, None], coh[:, None], 100.0, "hann", 64, 32,
                      averages, "constant")
    bb = SimpleNamespace(estimate=est, outputs=["acc"], speed_rad_s=2 * np.pi * 25.0,
                         models={"sampled": SimpleNamespace(freq_hz=freq,
                                                            responses={"acc": model})})
    note, = mapped_run.band_notes(SimpleNamespace(broadband=[bb]))
    assert note == ("acc at 25 Hz: coherence median 0.9000, min 0.9000 (7 of 10 bins below "
                    "0.98: not rated); H1 within +-2 sigma of the sampled-loop model in 60.0 % "
                    "of the bins (8 averages)")
    note, = mapped_run.band_notes(SimpleNamespace(broadband=[bb]), sigmas=4.0)
    assert "+-4 sigma of the sampled-loop model in 100.0 %" in note
    # noise-free (coherence 1, a band of zero width) and equal to the model: inside it
    exact = FrfEstimate(freq, model[:, None], model[:, None], np.ones((10, 1)), 100.0, "hann",
                        64, 32, averages, "constant")
    bb.estimate = exact
    note, = mapped_run.band_notes(SimpleNamespace(broadband=[bb]))
    assert "0 of 10 bins below 0.98" in note and "model in 100.0 % of the bins" in note


def test_three_finite_values_are_enough_for_a_channel():
    raw = np.array([1.0, np.nan, 2.0, 3.0])
    series = type("Series", (), {"topic": "/imu", "time_ns": np.arange(4) * 1000,
                                 "fields": {"data": raw}, "__getitem__": lambda s, k: raw})()
    bag = SimpleNamespace(topics={"/imu": series}, path="rig.mcap", series=lambda topic: series)
    t, y, excluded = mapped_run._read_field(bag, SignalMap(topic="/imu", field="data",
                                                           stamp="log"),
                                            "channels.foot_DL_az", "map.yaml")
    assert list(t) == [0, 2000, 3000] and list(y) == [1.0, 2.0, 3.0] and excluded == 1


def test_an_encoder_angle_of_two_whole_revolution_crossings_gives_the_top_speed():
    # 10 Hz from 0.08 revolutions: the angle crosses whole revolutions at 1 and 2 only
    t = np.linspace(0.0, 0.2, 201)
    theta = 2 * np.pi * (0.08 + 10.0 * t)
    shaft_map = ShaftMap(source="angle", topic="/enc")
    assert mapped_run.top_speed_hz(shaft_map, t, np.mod(theta, 2 * np.pi)) \
        == pytest.approx(10.0, rel=1e-9)
    with pytest.raises(ModelError, match="less than one revolution"):
        mapped_run.top_speed_hz(shaft_map, t[:150], np.mod(theta[:150], 2 * np.pi))
