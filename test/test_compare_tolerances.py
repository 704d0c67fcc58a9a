"""The compare tolerances applied where they belong: faults placed between two tolerances of
rotor_avc.compare.checks pass the looser check and fail the tighter one, a fault just inside a
tolerance passes and just outside fails, unsettled and dead points are told apart.

The "measurement" is the model itself -- a single mode H(f) = 1 / (1 - r^2 + 2j zeta r),
r = f / 10 Hz, zeta = 0.04 (half-power band 2 zeta f_n = 0.8 Hz) -- times a known fault at
chosen points, so each check's value is the fault put in (hand computation: 20 log10 of the
factor, its angle in degrees)."""
from types import SimpleNamespace

import numpy as np
import pytest

from rotor_avc.compare import checks
from rotor_avc.compare.checks import Broadband, OneX

FN_HZ, ZETA = 10.0, 0.04
F_MEAS = np.round(np.arange(4.0, 16.0001, 0.1), 10)
F_DENSE = np.linspace(2.0, 18.0, 1601)
CH = "foot_1_x"
RES = int(np.argmin(abs(F_MEAS - 10.0)))     # a point at the resonance (inside its band)
OFF = int(np.argmin(abs(F_MEAS - 5.0)))      # a point away from it


def mode(f, fn=FN_HZ):
    r = np.asarray(f) / fn
    return 1.0 / (1.0 - r ** 2 + 2j * ZETA * r)


def one_x(measured, drift=None, extra=None, f_meas=F_MEAS) -> OneX:
    """A OneX of channel CH (and ``extra`` channels: name -> (measured, model)) at ``f_meas``
    against the sampled model."""
    model = {CH: mode(f_meas)}
    dense = {CH: mode(F_DENSE)}
    meas = {CH: measured}
    for ch, (m, mod) in (extra or {}).items():
        meas[ch], model[ch], dense[ch] = m, mod(f_meas), mod(F_DENSE)
    one = OneX("test", {}, "unbalance", {}, 2 * np.pi * f_meas, meas, {"sampled": model},
               {"sampled": 2 * np.pi * F_DENSE}, {"sampled": dense}, drift=drift or {})
    checks._one_x_metrics(one)
    return one


def rated(one: OneX) -> dict:
    return {c.name: c for c in checks._one_x_checks(one, "sampled")}


def faulty(k, db=0.0, deg=0.0):
    meas = mode(F_MEAS)
    meas[k] *= 10 ** (db / 20) * np.exp(1j * np.radians(deg))
    return meas


def test_the_exact_model_passes_every_check_and_finds_its_resonance():
    one = one_x(mode(F_MEAS))
    assert all(c.passed for c in rated(one).values())
    (res,) = one.resonances
    assert res["model_hz"] == pytest.approx(FN_HZ * np.sqrt(1 - 2 * ZETA ** 2), rel=1e-4)
    assert one.channels["sampled"][CH]["at_resonance"][RES]
    assert not one.channels["sampled"][CH]["at_resonance"][OFF]
    assert one.channels["sampled"][CH]["checked_points"] == F_MEAS.size


@pytest.mark.parametrize("deg, at_passes", [(14.0, True), (16.0, False)])
def test_phase_at_a_resonance_between_the_tolerances(deg, at_passes):
    c = rated(one_x(faulty(RES, deg=deg)))
    assert c["1x phase error at resonances"].value == pytest.approx(deg, abs=1e-9)
    assert c["1x phase error at resonances"].passed is at_passes
    # the point is at a resonance: the tighter away-from-resonance tolerance does not apply
    assert c["1x phase error away from resonances"].passed


@pytest.mark.parametrize("deg, passes", [(4.5, True), (5.5, False)])
def test_phase_away_from_resonances(deg, passes):
    c = rated(one_x(faulty(OFF, deg=deg)))
    assert c["1x phase error away from resonances"].value == pytest.approx(deg, abs=1e-9)
    assert c["1x phase error away from resonances"].passed is passes
    assert c["1x phase error at resonances"].value == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("db, at_passes", [(1.0, True), (2.2, False)])
def test_magnitude_at_a_resonance_between_the_tolerances(db, at_passes):
    k = RES + 3                                 # inside the band, not the highest point
    c = rated(one_x(faulty(k, db=db)))
    assert c["1x magnitude error at resonances"].value == pytest.approx(db, abs=1e-9)
    assert c["1x magnitude error at resonances"].passed is at_passes
    assert c["1x magnitude error away from resonances"].passed


@pytest.mark.parametrize("db, passes", [(0.45, True), (0.55, False)])
def test_magnitude_away_from_resonances(db, passes):
    c = rated(one_x(faulty(OFF, db=db)))
    assert c["1x magnitude error away from resonances"].value == pytest.approx(db, abs=1e-9)
    assert c["1x magnitude error away from resonances"].passed is passes
    # one point in 121: the band RMS is db / sqrt(121)
    assert c["1x band RMS error"].value == pytest.approx(db / 11, rel=1e-9)


@pytest.mark.parametrize("db, passes", [(0.45, True), (0.55, False)])
def test_band_rms_of_a_uniform_error(db, passes):
    c = rated(one_x(mode(F_MEAS) * 10 ** (db / 20)))
    assert c["1x band RMS error"].value == pytest.approx(db, rel=1e-9)
    assert c["1x band RMS error"].passed is passes


@pytest.mark.parametrize("shift_pct, passes", [(0.5, True), (1.2, False)])
def test_resonance_frequency_error(shift_pct, passes):
    """Points 0.15 Hz apart (the three around the peak span 0.3 Hz, within half the 0.8 Hz
    band, and bracket the model's peak for either shift)."""
    f = np.round(np.arange(4.1, 16.0, 0.15), 10)
    c = rated(one_x(mode(f, FN_HZ * (1 + shift_pct / 100)), f_meas=f))
    check = c["resonance frequency error"]
    assert check.value == pytest.approx(shift_pct, abs=0.1)
    assert check.passed is passes
    # hand computation: the vertex of the parabola (dB) through the highest measured point and
    # its neighbours, x1 + h (y0 - y2) / (2 (y0 - 2 y1 + y2)), against the model's peak
    # fn sqrt(1 - 2 zeta^2), in percent
    db = 20 * np.log10(np.abs(mode(f, FN_HZ * (1 + shift_pct / 100))))
    i = int(np.argmax(db))
    y0, y1, y2 = db[i - 1:i + 2]
    vertex_hz = f[i] + 0.15 * (y0 - y2) / (2 * (y0 - 2 * y1 + y2))
    assert check.value == pytest.approx(
        100 * (vertex_hz / (FN_HZ * np.sqrt(1 - 2 * ZETA ** 2)) - 1), abs=1e-3)


def test_settling_tolerance_just_inside_is_checked_just_outside_is_left_out():
    meas = faulty(OFF, db=3.0)                  # fails the 0.5 dB check wherever it is rated
    drift = np.zeros(F_MEAS.size)
    drift[OFF] = 0.95 * checks.SETTLE_TOL
    inside = rated(one_x(meas, {CH: drift}))
    assert inside["1x magnitude error away from resonances"].passed is False
    assert not any(name.startswith("1x points not in steady state") for name in inside)
    drift[OFF] = 1.05 * checks.SETTLE_TOL
    one = one_x(meas, {CH: drift})
    outside = rated(one)
    assert outside["1x magnitude error away from resonances"].passed
    left = outside["1x points not in steady state, left out (1)"]
    assert left.value == pytest.approx(105 * checks.SETTLE_TOL) and left.passed is None
    assert left.tolerance == pytest.approx(2.0) and f"{F_MEAS[OFF]:.3f} Hz" in left.detail
    assert one.channels["sampled"][CH]["checked_points"] == F_MEAS.size - 1


def test_points_far_below_the_model_peak_are_not_rated():
    """A channel with a zero of its model at 7 Hz: the points within 40 dB of nothing (FLOOR_DB
    below the channel's peak) are not rated, however wrong the measurement there."""
    def notch(f):
        return mode(f) * (np.asarray(f) - 7.0) / 7.0
    k = int(np.argmin(abs(F_MEAS - 7.0)))
    meas = notch(F_MEAS)
    meas[k] = 1.0                               # the model is 0 there
    one = one_x(mode(F_MEAS), extra={"foot_2_x": (meas, notch)})
    c = one.channels["sampled"]["foot_2_x"]
    below = np.abs(notch(F_MEAS)) < np.abs(notch(F_DENSE)).max() * 10 ** (-40.0 / 20)
    # the zero and the points around it (about 50 dB below the peak) are not rated
    assert below[k] and below.sum() == 4 and c["checked_points"] == F_MEAS.size - 4
    assert rated(one)["1x magnitude error away from resonances"].passed


def test_a_point_exactly_floor_db_below_the_peak_is_rated():
    """The floor is inclusive: a model exactly 40 dB (a factor 0.01) below the channel's peak of
    1 is rated, one a bit (one unit in the last place) further below is not."""
    def step(f):
        f = np.asarray(f)
        return np.select([f < 5.0, f < 7.0], [np.nextafter(0.01, 0.0), 0.01], 1.0) + 0j
    one = one_x(mode(F_MEAS), extra={"foot_2_x": (step(F_MEAS), step)})
    assert one.channels["sampled"]["foot_2_x"]["checked_points"] == np.count_nonzero(F_MEAS >= 5)


def test_the_half_power_band_edges_are_at_the_resonance():
    """Measured at every point of the dense curve: the points at a resonance are exactly those
    within 3 dB of the dense curve's highest point, both band edges included."""
    one = one_x(mode(F_DENSE), f_meas=F_DENSE)
    db = 20 * np.log10(np.abs(mode(F_DENSE)))
    within = np.flatnonzero(db >= db.max() - 3.0)
    assert within.size > 2 and np.all(np.diff(within) == 1)     # one contiguous band
    assert np.array_equal(np.flatnonzero(one.channels["sampled"][CH]["at_resonance"]), within)


@pytest.mark.parametrize("db, dead", [(-100.0, False), (-130.0, True)])
def test_dead_channel_threshold(db, dead):
    one = one_x(mode(F_MEAS), extra={"foot_2_x": (mode(F_MEAS) * 10 ** (db / 20), mode)})
    check = checks._dead_channels(one, [], "sampled")
    if dead:
        assert (check.passed, check.value, check.tolerance) == (False, 1.0, 0.0)
        assert "foot_2_x" in check.detail
        assert one.channels["sampled"]["foot_2_x"]["checked_points"] == 0
        reason = checks._no_verdict_reason(SimpleNamespace(has_test_force=False), one, [], check)
        assert reason.startswith("every channel with a response is dead (foot_2_x")
    else:
        assert check is None
        assert rated(one)["1x magnitude error away from resonances"].value == pytest.approx(100.0)


def test_harmonic_forces_are_inputs_not_rated():
    one = one_x(mode(F_MEAS), extra={checks.HARMONIC + "f1": (mode(F_MEAS) * 5.0, mode)})
    assert "skipped" in one.channels["sampled"][checks.HARMONIC + "f1"]
    assert one.resonances == []                 # the harmonic forces drive the model: no peaks
    assert rated(one)["1x magnitude error away from resonances"].passed


@pytest.mark.parametrize("rms_db, phase_deg, passed", [(0.45, 4.5, (True, True)),
                                                      (0.55, 5.5, (False, False))])
def test_broadband_tolerances(rms_db, phase_deg, passed):
    bb = Broadband(2 * np.pi * 12.5, 0.0, None, ["a", "b"], (1.0, 50.0), {},
                   {"sampled": {"a": {"band_rms_db": -rms_db, "phase_rms_deg": 0.1, "dead": False},
                                "b": {"band_rms_db": 0.2, "phase_rms_deg": phase_deg,
                                      "dead": False}}})
    band, phase = checks._broadband_checks([bb], "sampled")
    assert band.name == "broadband H1 band RMS error at 12.500 Hz"
    assert (band.value, band.detail) == (pytest.approx(rms_db), "worst: a")
    assert (phase.value, phase.detail) == (pytest.approx(phase_deg), "worst: b")
    assert (band.passed, phase.passed) == passed
    assert checks._dead_channels(None, [bb], "sampled") is None


def test_worst_counts_an_infinite_error_and_skips_missing_ones():
    assert checks._worst([(None, "a"), (np.nan, "b")], "points") == (None, "no points")
    assert checks._worst([(-3.0, "a"), (2.0, "b")], "points") == (3.0, "worst: a")
    assert checks._worst([(1.0, "a"), (-np.inf, "b")], "points") == (np.inf, "worst: b")


def test_a_value_at_its_tolerance_passes():
    """Every tolerance is inclusive: errors of exactly 0.5 dB / 2 dB / 5 deg / 15 deg pass."""
    one = one_x(mode(F_MEAS))
    one.resonances = []
    one.channels["sampled"][CH] = {
        "error_db": np.array([0.5, 2.0]), "phase_error_deg": np.array([5.0, 15.0]),
        "at_resonance": np.array([False, True]), "band_rms_db": 0.5,
        "unsettled": np.array([False, False])}
    c = rated(one)
    assert [c[n].value for n in ("1x magnitude error away from resonances",
                                 "1x magnitude error at resonances",
                                 "1x phase error away from resonances",
                                 "1x phase error at resonances", "1x band RMS error")] == \
        [0.5, 2.0, 5.0, 15.0, 0.5]
    assert all(check.passed for check in c.values() if check.value is not None)
    bb = Broadband(2 * np.pi * 10.0, 0.0, None, ["a"], (1.0, 50.0), {},
                   {"sampled": {"a": {"band_rms_db": 0.5, "phase_rms_deg": 5.0, "dead": False}}})
    assert [x.passed for x in checks._broadband_checks([bb], "sampled")] == [True, True]


def test_nothing_to_rate_gets_its_reason():
    bb = Broadband(2 * np.pi * 10.0, 0.0, None, ["a"], (1.0, 50.0), {},
                   {"sampled": {"a": {"band_rms_db": None, "phase_rms_deg": None, "dead": False}}})
    band, _ = checks._broadband_checks([bb], "sampled")
    assert (band.value, band.passed, band.detail) == (None, None,
                                                      "no bins with coherence >= 0.98")
    one = one_x(mode(F_MEAS))
    forced = SimpleNamespace(has_test_force=True)
    assert checks._no_verdict_reason(forced, one, [], None).startswith(
        "the test force's dwells give no broadband estimate")
    assert checks._no_verdict_reason(forced, None, [bb], None) == \
        "no broadband bin reaches coherence 0.98"
    assert checks._no_verdict_reason(SimpleNamespace(has_test_force=False), None, [], None) \
        .startswith("nothing to compare")
    assert checks._no_verdict_reason(forced, one, [bb], None) == (
        "every 1x point is more than 40 dB below its channel's model peak or unrated (a run "
        "with a test force)")
    one.channels["sampled"][CH]["unsettled"][:3] = True
    assert checks._no_verdict_reason(forced, one, [bb], None).startswith(
        "every 1x point is left out: 3 point(s) not in steady state")
    # exit statuses of `rotor-avc compare` as documented: 0 pass, 1 fail, 5 no verdict
    assert checks.EXIT_NO_VERDICT == 5


def test_a_channel_the_model_does_not_move_is_skipped():
    one = one_x(mode(F_MEAS), extra={"foot_2_x": (mode(F_MEAS), lambda f: 0.0 * mode(f))})
    assert one.channels["sampled"]["foot_2_x"] == {"skipped": "the model's response is zero"}
    assert rated(one)["1x band RMS error"].value == pytest.approx(0.0, abs=1e-9)
