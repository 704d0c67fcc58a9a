"""FRF estimation (H1, H2, coherence) against known digital systems (scipy.signal.lfilter /
freqz), including the phase sign, output noise, and a synthetic bag of a known linear system."""
import numpy as np
import pytest
import scipy.signal as ss

from rotor_avc.analysis.frf_estimate import estimate_frf
from rotor_avc.bag import BagReader, topics as T, write_bag
from rotor_avc.errors import ModelError

FS = 1000.0
HIGH_COHERENCE = 0.999     # random error of |H1| ~ sqrt((1-g2)/(2 g2 n_avg)) < 0.5 % here


def resonance(f_hz=50.0, zeta=0.05):
    wn = 2 * np.pi * f_hz
    return ss.bilinear([wn**2], [1, 2 * zeta * wn, wn**2], FS)


def within(est_h, true_h, mask, db=0.1, deg=1.0):
    ratio = est_h[mask] / true_h[mask]
    return (np.max(np.abs(20 * np.log10(np.abs(ratio)))) <= db
            and np.max(np.abs(np.degrees(np.angle(ratio)))) <= deg)


def test_phase_sign_of_a_pure_delay():
    """y[k] = x[k-3]: H = e^{-j 2 pi f 3/fs}, a lagging (negative) phase slope."""
    x = np.random.default_rng(0).standard_normal(2**15)
    y = ss.lfilter([0, 0, 0, 1.0], [1.0], x)
    est = estimate_frf(x, y, FS, nperseg=1024)
    phase = np.unwrap(np.angle(est.h1))
    slope = np.polyfit(2 * np.pi * est.freq_hz, phase, 1)[0]
    np.testing.assert_allclose(slope, -3 / FS, rtol=1e-3)
    expected = np.exp(-2j * np.pi * est.freq_hz * 3 / FS)
    # (a delay of d samples leaks out of each segment: errors of the order d / nperseg)
    inner = slice(1, -1)
    assert within(est.h1[inner], expected[inner], slice(None))


@pytest.mark.parametrize("f_hz, zeta, nperseg", [(50.0, 0.05, 4096), (120.0, 0.02, 8192),
                                                 (20.0, 0.1, 2048)])
def test_resonant_system_recovered_where_coherence_is_high(f_hz, zeta, nperseg):
    b, a = resonance(f_hz, zeta)
    x = np.random.default_rng(1).standard_normal(2**17)
    y = ss.lfilter(b, a, x)
    est = estimate_frf(x, y, FS, nperseg=nperseg)
    _, h = ss.freqz(b, a, worN=est.freq_hz, fs=FS)
    mask = est.coherence >= HIGH_COHERENCE
    band = (est.freq_hz > 1) & (est.freq_hz < 0.8 * FS / 2)
    assert mask[band].mean() > 0.85      # leakage lowers it only around the resonance
    assert within(est.h1, h, mask) and within(est.h2, h, mask)
    fine = np.linspace(1, FS / 2, 200_001)
    true_peak = fine[np.argmax(np.abs(ss.freqz(b, a, worN=fine, fs=FS)[1]))]   # bilinear-warped
    assert abs(est.freq_hz[np.argmax(np.abs(est.h1))] - true_peak) <= est.resolution_hz


def test_output_noise_biases_h2_not_h1_and_coherence_is_their_ratio():
    b, a = resonance()
    rng = np.random.default_rng(2)
    x = rng.standard_normal(2**17)
    clean = ss.lfilter(b, a, x)
    y = clean + 0.05 * np.std(clean) * rng.standard_normal(x.size)
    est = estimate_frf(x, y, FS, nperseg=2048)
    _, h = ss.freqz(b, a, worN=est.freq_hz, fs=FS)
    band = (est.freq_hz > 5) & (est.freq_hz < 150)
    assert np.median(np.abs(est.h2[band]) / np.abs(h[band])) > np.median(
        np.abs(est.h1[band]) / np.abs(h[band]))
    np.testing.assert_allclose(est.coherence[band], (est.h1[band] / est.h2[band]).real,
                               rtol=1e-9)
    assert np.all(est.coherence <= 1 + 1e-12)
    strong = band & (est.coherence >= HIGH_COHERENCE)
    assert strong.any() and within(est.h1, h, strong)


def test_settings_stated_and_averages_counted_like_scipy():
    x = np.random.default_rng(3).standard_normal(10_000)
    est = estimate_frf(x, 2 * x, FS, nperseg=1000, noverlap=300, window="hamming")
    _, _, segments = ss.spectrogram(x, FS, nperseg=1000, noverlap=300)
    assert est.averages == segments.shape[-1] == 13
    s = est.settings()
    assert (s["window"], s["segment_length"], s["overlap"], s["resolution_hz"]) == (
        "hamming", 1000, 300, 1.0)
    default = estimate_frf(x, x, FS)
    assert default.nperseg == 1024 and default.noverlap == 512 and default.averages >= 16


def test_multiple_outputs_equal_single_calls():
    rng = np.random.default_rng(4)
    x = rng.standard_normal(2**14)
    b, a = resonance()
    y = np.column_stack([ss.lfilter(b, a, x), ss.lfilter([0, 1.0], [1.0], x)])
    both = estimate_frf(x, y, FS, nperseg=1024)
    for i in range(2):
        one = estimate_frf(x, y[:, i], FS, nperseg=1024)
        np.testing.assert_allclose(both.h1[:, i], one.h1)
        np.testing.assert_allclose(both.h2[:, i], one.h2)
        np.testing.assert_allclose(both.coherence[:, i], one.coherence)


def test_known_system_recovered_from_a_synthetic_bag(tmp_path):
    """Broadband actuator force -> foot acceleration through a known filter, recorded as a bag
    (WrenchStamped / AccelStamped), read back and estimated: within 0.1 dB / 1 degree."""
    rng = np.random.default_rng(5)
    n = 2**16
    t = np.arange(n) / FS
    force = 100 * rng.standard_normal(n)
    b, a = resonance(80.0, 0.03)
    b = -0.02 * np.asarray(b)                              # a sign and a gain: m/s^2 per N
    accel = ss.lfilter(b, a, force)
    path = write_bag(tmp_path / "broadband.mcap",
                     [T.actuator_force("DL", t, force), T.foot_acceleration("DL", t, accel)],
                     {"machine": {"model": "filter"}, "discretisation": {"sample_rate_hz": FS}})
    with BagReader(path, require_config=True) as bag:
        fs = bag.config["discretisation"]["sample_rate_hz"]
        x = bag.series("/avc/foot/DL/actuator_force")
        y = bag.series("/avc/foot/DL/acceleration")
    np.testing.assert_array_equal(x.time_ns, y.time_ns)
    est = estimate_frf(x["wrench.force.z"], y["accel.linear.z"], fs, nperseg=4096)
    _, h = ss.freqz(b, a, worN=est.freq_hz, fs=FS)
    mask = est.coherence >= HIGH_COHERENCE
    assert mask.mean() > 0.8 and within(est.h1, h, mask) and within(est.h2, h, mask)


@pytest.mark.parametrize("args, kwargs, problem", [
    ((np.ones(100), np.ones(99), FS), {}, "x must be"),
    ((np.r_[np.nan, np.ones(99)], np.ones(100), FS), {}, "NaN"),
    ((np.arange(100.0), np.ones(100), 0.0), {}, "sample rate"),
    ((np.arange(100.0), np.ones(100), FS), {"nperseg": 200}, "segment length <= 100"),
    ((np.arange(100.0), np.ones(100), FS), {"nperseg": 64, "noverlap": 64}, "overlap"),
    ((np.ones(300), np.ones(300), FS), {}, "constant"),
])
def test_errors_name_the_problem(args, kwargs, problem):
    with pytest.raises(ModelError, match=problem):
        estimate_frf(*args, **kwargs)
