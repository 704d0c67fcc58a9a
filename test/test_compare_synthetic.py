"""The comparison's extraction on a synthetic bag from a known linear system: the 1x phasors and
the broadband FRF read back from the bag equal the system's own response (0.1 dB / 1 degree
where the coherence is high), phase sign included (a known delay must come out as a lag)."""
from pathlib import Path

import numpy as np
import pytest
import scipy.signal

from rotor_avc.compare.comparison import broadband_outputs, measured_broadband, measured_one_x
from rotor_avc.compare.recorded_run import read_run
from rotor_avc.bag import topics as T
from rotor_avc.bag.writer import write_bag
from rotor_avc.config import load_yaml
from rotor_avc.scenario import scenario_from_config

ROOT = Path(__file__).resolve().parents[1]
FS = 2000.0
SPEEDS_HZ = [20.0, 37.3]         # 37.3 Hz: a non-integer number of samples per revolution


def scenario_config():
    data = load_yaml(ROOT / "config" / "scenario_reference.yaml")
    data["simulation"] = {
        "sample_rate_hz": FS,
        "speed": {"type": "stepped", "speeds_hz": SPEEDS_HZ, "dwell_s": 30.0, "transition_s": 0.2},
        "unbalance": {"static": {"magnitude": 2.0e-2, "phase_deg": 30.0}},
        "test_signal": {"actuator": "DL", "kind": "white", "rms_n": 50.0, "band_hz": [5.0, 600.0],
                        "seed": 7}}
    return data


def known_1x(speed_rad_s):
    """A single-degree-of-freedom mobility (m/s per kg m), 45 Hz, 4 % damping."""
    w0, zeta = 2 * np.pi * 45.0, 0.04
    s = 1j * speed_rad_s
    return s * speed_rad_s ** 2 / (s * s + 2 * zeta * w0 * s + w0 * w0)


def known_filter():
    """A resonance at 180 Hz (10 % damping, bilinear) behind a 3-sample delay."""
    w0, zeta = 2 * np.pi * 180.0, 0.1
    b, a = scipy.signal.bilinear([w0 * w0], [1.0, 2 * zeta * w0, w0 * w0], fs=FS)
    return np.concatenate([np.zeros(3), b]), a


def synthetic_bag(path, with_test_topic: bool = True):
    data = scenario_config()
    sc = scenario_from_config(data, "synthetic")
    n = sc.n_steps
    t = np.arange(n) / FS
    speed, _, angle = sc.profile.sample(t)
    u = sc.amplitudes["static"]
    one_x = (known_1x(speed) * u * np.exp(1j * angle)).real          # y = Re{G u e^{j theta}}
    d = sc.test_force.values(0, n)
    b, a = known_filter()
    y = scipy.signal.lfilter(b, a, d)
    streams = [T.joint_state(t, angle, speed), T.clock(t),
               T.labelled_array("plant/observables", t, ["time_s", "bearing_N_vz", "foot_DL_az"],
                                np.column_stack([t, one_x, y]))]
    if with_test_topic:
        streams.append(T.labelled_array("plant/test_signal", t, ["time_s", sc.test_force.channel],
                                        np.column_stack([t, d])))
    write_bag(path, streams, sc.run_config())
    return path


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return read_run(synthetic_bag(tmp_path_factory.mktemp("synthetic") / "synthetic.mcap"))


def test_synthetic_bag_recovers_the_known_system(run):
    assert run.test_source.startswith("recorded")

    u = run.scenario.amplitudes["static"]
    track, method, _ = measured_one_x(run, u)
    assert method == "stepped-speed dwells"
    np.testing.assert_allclose(track.speed_hz, SPEEDS_HZ, rtol=1e-9)
    truth = known_1x(track.speed_rad_s)
    got = track.phasors["bearing_N_vz"]
    assert np.all(np.abs(20 * np.log10(np.abs(got / truth))) < 0.1)
    assert np.all(np.abs(np.degrees(np.angle(got / truth))) < 1.0)

    estimates = measured_broadband(run)
    assert [round(s / (2 * np.pi), 6) for s, _ in estimates] == SPEEDS_HZ
    b, a = known_filter()
    for _, est in estimates:
        col = broadband_outputs(run).index("foot_DL_az")
        assert est.averages >= 8 and est.window == "hann"
        f = est.freq_hz
        band = (f >= 5.0) & (f <= 600.0)
        coherent = band & (est.coherence[:, col] >= 0.99)
        assert coherent.sum() > 0.9 * band.sum()
        _, h = scipy.signal.freqz(b, a, worN=f[coherent], fs=FS)
        h1 = est.h1[coherent, col]
        assert np.max(np.abs(20 * np.log10(np.abs(h1 / h)))) < 0.1
        assert np.max(np.abs(np.degrees(np.angle(h1 / h)))) < 1.0
        # phase sign: well above the resonance the 3-sample delay dominates, a lag growing with
        # frequency (slope -2 pi 3 / fs rad/Hz), as scipy.signal.freqz says
        hi = coherent & (f > 400.0)
        slope = np.polyfit(f[hi], np.unwrap(np.angle(est.h1[hi, col])), 1)[0]
        assert slope < 0 and abs(slope / (-2 * np.pi * 3 / FS) - 1) < 0.2


def test_a_bag_without_the_test_topic_regenerates_the_same_force(run, tmp_path):
    """A plant that did not publish plant/test_signal: d_k comes from the configuration."""
    other = read_run(synthetic_bag(tmp_path / "no_topic.mcap", with_test_topic=False))
    assert other.test_source.startswith("regenerated")
    np.testing.assert_array_equal(other.test_force, run.test_force)
