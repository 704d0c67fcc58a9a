"""API 684 checks against the exact half-power points of a single-degree-of-freedom oscillator
and the standard's required-margin formulas."""
import json

import numpy as np
import pytest

from rotor_avc.analysis.api684 import (_af_bound, check_critical, check_response, format_table,
                                       half_power_points, required_margin_pct)
from rotor_avc.analysis.campbell import campbell_diagram
from rotor_avc.cli import main
from rotor_avc.errors import ModelError
from rotor_avc.machine import load_machine


def sdof(speed_hz, fn_hz, zeta):
    r = speed_hz / fn_hz
    return 1.0 / np.sqrt((1 - r**2) ** 2 + (2 * zeta * r) ** 2)


def exact_af(zeta):
    """|H| = 1/sqrt((1-r^2)^2 + (2 zeta r)^2): peak at r^2 = 1 - 2 zeta^2, half-power points at
    r^2 = 1 - 2 zeta^2 -+ 2 zeta sqrt(1 - zeta^2)."""
    mid, half = 1 - 2 * zeta**2, 2 * zeta * np.sqrt(1 - zeta**2)
    return np.sqrt(mid) / (np.sqrt(mid + half) - np.sqrt(mid - half))


@pytest.mark.parametrize("zeta", [0.01, 0.05, 0.15])
def test_amplification_factor_of_a_single_mode(zeta):
    speed = np.linspace(5.0, 95.0, 20001)
    (c,) = check_response(speed, sdof(speed, 40.0, zeta), operating_hz=(60.0, 80.0))
    assert c.speed_hz == pytest.approx(40.0 * np.sqrt(1 - 2 * zeta**2), abs=0.01)
    assert c.amplification_factor == pytest.approx(exact_af(zeta), rel=2e-3)
    assert c.amplification_factor == pytest.approx(1 / (2 * zeta), rel=0.05)    # API 684 Fig. 2-6
    assert c.peak == pytest.approx(1 / (2 * zeta * np.sqrt(1 - zeta**2)), rel=1e-4)
    assert c.position == "below"
    assert c.separation_margin_pct == pytest.approx(100 * (60.0 - c.speed_hz) / 60.0)


def test_the_critically_damped_line_is_at_af_2_5():
    """No margin below AF = 2.5, the formula's from there (a line moved to 3 or 3.5 fails)."""
    assert required_margin_pct(2.49, "above") == 0.0 and required_margin_pct(2.49, "below") == 0.0
    assert required_margin_pct(2.6, "below") == pytest.approx(17 * (1 - 1 / 1.1))
    assert required_margin_pct(2.6, "above") == pytest.approx(10 + 17 * (1 - 1 / 1.1))
    assert required_margin_pct(3.0, "below") == pytest.approx(17 / 3)


def test_required_margins_are_the_standards():
    assert required_margin_pct(2.0, "below") == 0.0
    assert required_margin_pct(5.0, "below") == pytest.approx(17 * (1 - 1 / 3.5))
    assert required_margin_pct(5.0, "above") == pytest.approx(10 + 17 * (1 - 1 / 3.5))
    assert required_margin_pct(50.0, "below") == 16.0        # caps
    assert required_margin_pct(50.0, "above") == 26.0


def test_verdicts():
    speed = np.linspace(5.0, 150.0, 20001)
    amp = sdof(speed, 40.0, 0.02) + sdof(speed, 120.0, 0.02)
    below, above = check_response(speed, amp, operating_hz=(45.0, 100.0))
    assert below.position == "below" and below.verdict == "fail"      # 11 % < 16 % required
    assert above.position == "above" and above.verdict == "fail"      # 20 % < 26 %
    below, above = check_response(speed, amp, operating_hz=(50.0, 90.0))
    assert below.verdict == "pass" and above.verdict == "pass"        # 20 % and 33 %
    (inside, _) = check_response(speed, amp, operating_hz=(30.0, 60.0))
    assert inside.position == "within" and inside.verdict == "fail"
    for zeta in (0.3, 0.4):          # 0.4: the response never falls to 0.707 x peak below it
        heavy = check_response(speed, sdof(speed, 40.0, zeta), operating_hz=(45.0, 100.0))
        assert [c.verdict for c in heavy] == ["critically damped"]
    text = format_table(check_response(speed, amp, (50.0, 90.0)), "m/s", (50.0, 90.0))
    assert "pass" in text and "3000 .. 5400 rpm" in text


def test_half_power_outside_the_record_is_undetermined():
    speed = np.linspace(38.0, 60.0, 500)             # starts above the lower half-power point
    amp = sdof(speed, 40.0, 0.05)
    i = int(np.argmax(amp))
    n1, n2 = half_power_points(speed, amp, i)
    assert n1 is None and n2 == pytest.approx(40 * np.sqrt(1 - 2 * 0.05**2 + 2 * 0.05 * np.sqrt(1 - 0.05**2)), rel=1e-3)


def test_bad_input_is_refused():
    with pytest.raises(ModelError, match="increase"):
        check_response([3.0, 2.0, 1.0], [1.0, 2.0, 1.0], (1.0, 2.0))
    with pytest.raises(ModelError, match="operating speed range"):
        check_response([1.0, 2.0, 3.0], [1.0, 2.0, 1.0], (0.0, 2.0))


def test_model_check_agrees_with_the_campbell_damping(capsys):
    """An isolated mode of Werner 2019's motor: AF of the bearing response ~ 1 / (2 zeta) of the
    mode where it crosses 1x (Campbell diagram, forced-response damping)."""
    assert main(["api684", "sleeve_bearing_motor", "--operating-hz", "55:65", "--speed-hz",
                 "5:75:1401", "--responses", "bearing_vz_mass_eccentricity", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    (check,) = data["responses"]["bearing_vz_mass_eccentricity"]
    assert check["verdict"] == "pass" and check["position"] == "below"
    cd = campbell_diagram(load_machine("sleeve_bearing_motor"),
                          2 * np.pi * np.linspace(15.0, 25.0, 41), rule="forced")
    crossing = min(cd.critical_speeds((1,)), key=lambda r: abs(r["speed_hz"] - check["speed_hz"]))
    assert crossing["speed_hz"] == pytest.approx(check["speed_hz"], rel=0.01)
    k = cd.labels.index(crossing["mode"])
    zeta = np.interp(crossing["speed_hz"], cd.speed_hz, cd.damping_ratio[:, k])
    assert check["amplification_factor"] == pytest.approx(1 / (2 * zeta), rel=0.1)


def test_half_power_points_interpolate_between_neighbouring_samples():
    """Hand computation: level 1/sqrt(2) crossed between samples 1 and 2 (left) and 4 and 5
    (right), each interpolated linearly between those two neighbours."""
    speed = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    amp = np.array([0.5, 0.6, 0.9, 1.0, 0.8, 0.3])
    level = 1 / np.sqrt(2)
    n1, n2 = half_power_points(speed, amp, 3)
    assert n1 == pytest.approx(3.0 - (0.9 - level) / (0.9 - 0.6))
    assert n2 == pytest.approx(5.0 + (0.8 - level) / (0.8 - 0.3))


def test_a_sample_exactly_at_the_half_power_level_is_the_half_power_point():
    """The amplitude falls to peak / sqrt(2) exactly at 2 Hz and at 4 Hz (then rises to a
    second peak): those are N_1 and N_2, not a later crossing."""
    level = 1 / np.sqrt(2)
    speed = np.arange(1.0, 8.0)
    amp = np.array([0.1, level, 1.0, level, 0.9, 0.2, 0.1])
    assert half_power_points(speed, amp, 2) == (2.0, 4.0)


def test_an_af_bound_of_exactly_2_5_leaves_the_af_undetermined():
    """N_1 = 4 Hz (a sample exactly at the level), no N_2 before the record ends at 6 Hz: AF is
    at most 5 / (6 - 4) = 2.5, which is not below 2.5 -- not known to be critically damped."""
    speed = np.arange(1.0, 7.0)
    amp = np.array([0.1, 0.3, 0.5, 1 / np.sqrt(2), 1.0, 0.9])
    c = check_critical(speed, amp, 4, (20.0, 30.0))
    assert (c.n1_hz, c.n2_hz, c.amplification_factor) == (4.0, None, None)
    assert (c.verdict, c.required_margin_pct) == ("undetermined", None)


@pytest.mark.parametrize("nc_hz", [100.0, 120.0])
def test_a_critical_at_either_end_of_the_operating_range_lies_within_it(nc_hz):
    """The operating range [N_min, N_mc] = [100, 120] Hz is closed: a sharp critical (AF ~ 1000)
    at 100 Hz or at 120 Hz is inside it and fails, with no separation margin."""
    speed = nc_hz + np.array([-1.0, -0.1, 0.0, 0.1, 1.0])
    amp = np.array([0.1, 0.1, 1.0, 0.1, 0.1])
    c = check_critical(speed, amp, 2, (100.0, 120.0))
    assert c.amplification_factor > 1000
    assert (c.position, c.separation_margin_pct, c.verdict) == ("within", None, "fail")


def test_at_af_2_5_the_formula_applies():
    """API 617 6.8.2.10: AF >= 2.5 is not critically damped; 17 (1 - 1 / (2.5 - 1.5)) = 0."""
    assert required_margin_pct(2.5, "above") == 10.0
    assert required_margin_pct(2.5, "below") == 0.0


def test_the_af_bound_spans_the_found_point_to_the_record_end():
    speed = np.array([1.0, 2.0, 4.0, 7.0])
    assert _af_bound(speed, 3.0, None, 3.5) == pytest.approx(3.0 / (3.5 - 1.0))
    assert _af_bound(speed, 3.0, 2.5, None) == pytest.approx(3.0 / (7.0 - 2.5))
    assert _af_bound(speed, 3.0, None, None) == np.inf


def test_a_broad_peak_with_one_half_power_point_is_critically_damped():
    speed = np.arange(1.0, 10.0)
    amp = np.array([0.5, 0.8, 0.9, 1.0, 0.95, 0.9, 0.85, 0.8, 0.78])
    c = check_critical(speed, amp, 3, (20.0, 30.0))
    n1 = 2.0 - (0.8 - 1 / np.sqrt(2)) / (0.8 - 0.5)
    assert (c.n1_hz, c.n2_hz, c.amplification_factor) == (pytest.approx(n1), None, None)
    assert (c.verdict, c.required_margin_pct) == ("critically damped", 0.0)   # 4 / (9 - n1) < 2.5


def test_a_margin_equal_to_the_required_passes():
    """A sharp peak (AF ~ 1400: required margin capped at 16 %) at 84 Hz below a range from
    100 Hz: SM = 100 (100 - 84) / 100 = 16 % exactly, which meets the requirement."""
    speed = np.array([83.0, 83.9, 84.0, 84.1, 85.0])
    amp = np.array([0.1, 0.1, 1.0, 0.1, 0.1])
    c = check_critical(speed, amp, 2, (100.0, 120.0))
    assert c.amplification_factor > 1000
    assert (c.separation_margin_pct, c.required_margin_pct) == (16.0, 16.0)
    assert c.verdict == "pass"


def test_short_records_and_low_operating_ranges():
    with pytest.raises(ModelError, match="equal length >= 3"):
        check_response([1.0, 2.0], [0.5, 1.0], (5.0, 6.0))
    with pytest.raises(ModelError, match="equal length >= 3"):
        check_response([1.0, 2.0, 3.0], [0.5, 1.0, 0.5, 0.2], (5.0, 6.0))
    # an operating range below 1 Hz (60 rpm) is a range like any other
    speed = np.linspace(0.1, 2.0, 200)
    (c,) = check_response(speed, sdof(speed, 1.0, 0.05), (0.5, 0.8))
    # the amplitude peak at sqrt(1 - 2 zeta^2) = 0.9975 Hz: SM = 100 (0.9975 - 0.8) / 0.8 = 24.7 %
    assert c.position == "above" and c.separation_margin_pct == pytest.approx(24.69, abs=0.05)
