"""Speed profiles: the shaft angle is the integral of the speed, the acceleration its slope;
config forms and their errors."""
import numpy as np
import pytest
from scipy.integrate import quad

from rotor_avc.config import Section
from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.sim.speed_profile import (constant_speed, profile_from_config, ramp, sequence,
                                         stepped)

TWO_PI = 2 * np.pi


def check_angle_is_integral(profile, t_end):
    t = np.linspace(0.0, t_end, 37)
    speed, _, angle = profile.sample(t)
    for ti, th in zip(t, angle):
        ref, _ = quad(lambda s: float(profile.sample(np.array(s))[0]), 0.0, ti, limit=200,
                      points=profile.times_s[(profile.times_s > 0) & (profile.times_s < ti)])
        assert th == pytest.approx(ref, rel=1e-10, abs=1e-9)


@pytest.mark.parametrize("profile, t_end", [
    (constant_speed(100.0), 3.0),
    (ramp(0.0, 2 * np.pi * 30, 7.0), 9.0),
    (ramp(300.0, 50.0, 2.0), 3.0),
    (stepped([10.0, 60.0, 20.0], 1.0, 0.25), 4.0),
    (stepped([10.0, 60.0], 1.0, 0.0), 2.5),
    (sequence([constant_speed(5.0, 1.0), ramp(5.0, 80.0, 2.0), stepped([40.0, 90.0], 0.5)]), 5.0),
])
def test_angle_and_acceleration(profile, t_end):
    check_angle_is_integral(profile, t_end)
    # acceleration: central difference of the speed away from the knots
    t = np.linspace(0.013, t_end - 0.013, 200)
    h = 1e-6
    near_knot = np.min(np.abs(t[:, None] - profile.times_s[None, :]), axis=1) < 2 * h
    fd = (profile.sample(t + h)[0] - profile.sample(t - h)[0]) / (2 * h)
    np.testing.assert_allclose(profile.sample(t)[1][~near_knot], fd[~near_knot], atol=1e-5)


def test_shapes_and_lengths():
    r = ramp(10.0, 110.0, 4.0)
    assert r.length_s == 4.0
    speed, accel, _ = r.sample(np.array([0.0, 2.0, 4.0, 10.0]))
    np.testing.assert_allclose(speed, [10.0, 60.0, 110.0, 110.0])       # held after the end
    np.testing.assert_allclose(accel, [25.0, 25.0, 0.0, 0.0])
    s = stepped([1.0, 2.0, 3.0], dwell_s=2.0, transition_s=0.5)
    assert s.length_s == pytest.approx(7.0)
    np.testing.assert_allclose(s.sample(np.array([1.0, 2.25, 3.0, 6.9]))[0], [1.0, 1.5, 2.0, 3.0])
    np.testing.assert_array_equal(np.sort(s.held_speeds()), [1.0, 2.0, 3.0])
    jump = stepped([1.0, 5.0], dwell_s=1.0)
    assert jump.sample(np.array(1.0))[0] == 5.0                  # right-continuous at a jump
    seq = sequence([constant_speed(3.0, 1.0), ramp(3.0, 9.0, 1.0)])
    np.testing.assert_allclose(seq.sample(np.array([0.5, 1.0, 1.5, 2.0]))[0], [3.0, 3.0, 6.0, 9.0])
    assert constant_speed(4.0).length_s is None


def test_config_forms():
    prof = profile_from_config(Section({"type": "ramp", "start_hz": 0.0, "stop_hz": 30.0,
                                        "rate_hz_per_s": 10.0}, "simulation.speed"))
    assert prof.length_s == pytest.approx(3.0)
    assert prof.max_speed_rad_s == pytest.approx(TWO_PI * 30)
    seq = profile_from_config(Section({"type": "sequence", "parts": [
        {"type": "constant", "speed_hz": 10.0, "duration_s": 1.0},
        {"type": "stepped", "speeds_hz": [20.0, 30.0], "dwell_s": 1.0, "transition_s": 0.2}]}))
    assert seq.length_s == pytest.approx(3.2)
    np.testing.assert_allclose(seq.sample(np.array([0.5, 1.5, 3.0]))[0] / TWO_PI, [10, 20, 30])


@pytest.mark.parametrize("data, field", [
    ({"type": "warp"}, "type"),
    ({"type": "constant", "speed_hz": -5.0}, "speed_hz"),
    ({"type": "constant", "speed_hz": 5.0, "duration_s": 0.0}, "duration_s"),
    ({"type": "ramp", "start_hz": 0.0, "stop_hz": 10.0}, "duration_s"),
    ({"type": "ramp", "start_hz": 0.0, "stop_hz": 10.0, "duration_s": 1.0, "rate_hz_per_s": 1.0},
     "duration_s"),
    ({"type": "ramp", "start_hz": 5.0, "stop_hz": 5.0, "duration_s": 1.0}, "stop_hz"),
    ({"type": "stepped", "speeds_hz": [1.0, -2.0], "dwell_s": 1.0}, "speeds_hz"),
    ({"type": "stepped", "speeds_hz": [1.0], "dwell_s": 1.0, "spped": 3}, "spped"),
    ({"type": "sequence", "parts": []}, "parts"),
    ({"type": "sequence", "parts": [{"type": "constant", "speed_hz": 1.0},
                                    {"type": "constant", "speed_hz": 2.0}]}, "parts[0].duration_s"),
])
def test_config_errors_name_the_field(data, field):
    with pytest.raises(ConfigError) as exc:
        profile_from_config(Section(data, "simulation.speed"))
    assert exc.value.field == f"simulation.speed.{field}"


def test_profile_validation():
    with pytest.raises(ModelError, match=">= 0"):
        ramp(10.0, -1.0, 1.0)
    with pytest.raises(ModelError, match="open-ended"):
        sequence([constant_speed(1.0), constant_speed(2.0, 1.0)])
