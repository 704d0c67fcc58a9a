"""Resonance peaks (rotor_avc.analysis.resonance_peaks) against a single mode in closed form:
the displacement peak of 1/(w0^2 - w^2 + 2j zeta w0 w) lies at w0 sqrt(1 - 2 zeta^2), its
half-power band is about 2 zeta f0 wide, and a few measured points resolve it."""
import numpy as np
import pytest

from rotor_avc.analysis.resonance_peaks import measured_resonance, model_peaks, parabolic_vertex

F0, ZETA = 105.0, 0.04


def mode(f_hz):
    w, w0 = 2 * np.pi * np.asarray(f_hz, float), 2 * np.pi * F0
    return 1.0 / (w0 ** 2 - w ** 2 + 2j * ZETA * w0 * w)


def db(v):
    return 20 * np.log10(np.abs(v))


def test_dense_peak_and_half_power_band():
    f = np.linspace(60.0, 150.0, 2001)
    [peak] = model_peaks(f, mode(f))
    f_peak = F0 * np.sqrt(1 - 2 * ZETA ** 2)
    assert peak["freq_hz"] == pytest.approx(f_peak, abs=1e-3)
    assert peak["level_db"] == pytest.approx(db(mode(f_peak)), abs=1e-4)
    lo, hi = peak["band_hz"]
    assert hi - lo == pytest.approx(2 * ZETA * F0, rel=0.02)
    assert model_peaks(f, np.ones_like(f)) == []               # no peak on a flat curve


@pytest.mark.parametrize("spacing_hz, tol_pct", [(1.0, 0.05), (2.0, 0.15)])
def test_measured_points_resolve_the_peak(spacing_hz, tol_pct):
    f = np.linspace(60.0, 150.0, 2001)
    [peak] = model_peaks(f, mode(f))
    for centre in (103.3, 104.0, 105.5, 106.7):              # the grid anywhere around the peak
        pts = centre + spacing_hz * np.arange(-3, 4)
        found, why = measured_resonance(pts, db(mode(pts)), peak)
        assert why == "" and abs(found["freq_hz"] / peak["freq_hz"] - 1) < tol_pct / 100
        assert abs(found["level_db"] - peak["level_db"]) < 0.5


def test_unresolved_peaks_say_why():
    f = np.linspace(60.0, 150.0, 2001)
    [peak] = model_peaks(f, mode(f))
    assert "not bracketed" in measured_resonance(np.array([100.0, 103.0]),
                                                 db(mode([100.0, 103.0])), peak)[1]
    wide = np.array([100.0, 104.0, 108.0])                     # band 8.4 Hz, span 8 Hz
    assert "more than half its half-power band" in measured_resonance(wide, db(mode(wide)),
                                                                      peak)[1]
    assert "no measured speed" in measured_resonance(np.array([50.0, 60.0, 70.0]),
                                                     db(mode([50.0, 60.0, 70.0])), peak)[1]


def test_parabolic_vertex_is_exact_for_a_parabola():
    x = np.array([1.0, 2.5, 3.0])
    assert parabolic_vertex(x, -(x - 2.2) ** 2 + 7.0) == pytest.approx((2.2, 7.0))
    assert parabolic_vertex(x, (x - 2.2) ** 2) == (2.5, pytest.approx(0.09))   # not a maximum
