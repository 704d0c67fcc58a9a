"""The design check covers every held speed of a run and warns about aliasing modes at the
Nyquist limit (rotor_avc.analysis.design_check).

* Speeds: a stepped run is checked at its extremes AND its held speeds (at most MAX_SPEEDS). The
  case-3 machine with a slightly negative controller gain (ki = -1.4e3, -1 % of the shipped
  Werner 2021 eq. 50 value) is unstable exactly where its loss-factor damping is low; with the
  damping frequency w_F frozen at 20 Hz except at the held middle speed of a 10 / 40 / 105 Hz
  run (there w_F = 200 Hz: a tenth of the loss damping), the loop is unstable at 40 Hz only. The
  check at the two extremes alone passes it (shown here), so only a check of the held speeds
  refuses it.
* Aliasing: the six modes of interest of case 3 (analysis.worst_case.n_modes) have undamped
  natural frequencies up to f6 = 104.7 Hz (eigenvalues of K, M computed here); a sample rate
  fs puts a mode in the warning exactly when f >= fs / 2 (the Nyquist frequency), so f6 at
  fs = 150 Hz (between fs / 2 and fs) is warned about and nothing at fs = 220 Hz (f6 < fs / 2).
* Divergence of a run allowed to be unstable: a channel e^(sigma t) grows by e^(sigma 9 s)
  between the largest values of the first and the last tenth of a 10 s run, the growth rate
  between the tenths' mid-times is sigma (hand computation in the test), and that rate names
  the unstable pole nearest to it.
"""
import math
from dataclasses import dataclass, replace

import numpy as np
import pytest
import yaml

from rotor_avc.analysis.design_check import (DIVERGENCE_GROWTH, DesignCheck, DesignError,
                                             DivergenceWatch, MAX_SPEEDS, check_design,
                                             check_scenario, enforce_scenario, fault_summary,
                                             natural_frequencies_hz, scenario_speeds)
from rotor_avc.analysis.sampled_loop import SampledLoop
from rotor_avc.config import find_config
from rotor_avc.control.block import build_digital_controllers
from rotor_avc.scenario import load_scenario

CASE3 = ("DL", "DR", "NL")
TWO_PI = 2 * math.pi


def test_a_stepped_run_is_checked_at_each_held_speed():
    sc = load_scenario("scenario_case3_stepped")
    held_hz = yaml.safe_load(find_config("scenario_case3_stepped.yaml").read_text())[
        "simulation"]["speed"]["speeds_hz"]                   # [10, 20, 40, 80, 105]
    assert len(held_hz) <= MAX_SPEEDS
    np.testing.assert_allclose(scenario_speeds(sc.profile), TWO_PI * np.array(held_hz),
                               rtol=1e-15)


@dataclass(frozen=True)
class LowDampingAt:
    """A damping rule: w_F frozen at ``base_hz``, except ``at_hz`` -> ``w_F_hz`` there."""

    at_hz: float
    w_F_hz: float
    base_hz: float = 20.0

    def w_F(self, plant, speed_rad_s):
        hz = self.w_F_hz if abs(speed_rad_s / TWO_PI - self.at_hz) < 1e-9 else self.base_hz
        return TWO_PI * hz


def middle_speed_scenario(tmp_path):
    path = tmp_path / "middle.yaml"
    path.write_text(yaml.safe_dump({
        "include": str(find_config("scenario_case3_stepped.yaml").resolve()),
        "controllers": {f: {"ki": -1.4e3} for f in CASE3},
        "simulation": {"speed": {"type": "stepped", "speeds_hz": [10.0, 40.0, 105.0],
                                 "dwell_s": 1.0, "transition_s": 0.5},
                       "initial_state": "rest"}}))
    return replace(load_scenario(path), damping=LowDampingAt(at_hz=40.0, w_F_hz=200.0))


def test_a_run_unstable_only_at_its_held_middle_speed_is_refused(tmp_path):
    sc = middle_speed_scenario(tmp_path)
    machine, plant = sc.machine, sc.machine.plant
    w_F = lambda w: sc.damping.w_F(plant, w)                   # noqa: E731
    extremes = check_design(machine, sc.sample_period_s, TWO_PI * np.array([10.0, 105.0]), w_F)
    assert extremes.ok and not extremes.unstable_poles         # the extremes alone pass
    middle = check_design(machine, sc.sample_period_s, [TWO_PI * 40.0], w_F)
    assert not middle.ok                                       # the middle speed is unstable
    chk = check_scenario(sc)
    assert not chk.ok and chk.unstable_poles
    assert {round(r["speed_hz"], 9) for r in chk.unstable_poles} == {40.0}
    with pytest.raises(DesignError, match="UNSTABLE.*at 40 Hz shaft speed"):
        enforce_scenario(sc, "simulate")


@pytest.fixture(scope="module")
def case3():
    sc = load_scenario("scenario_case3_steady")
    machine = sc.machine
    f = natural_frequencies_hz(machine.plant)[:machine.analysis.worst_case.n_modes]
    return machine, f


def warnings_at(machine, fs_hz):
    return check_design(machine, 1.0 / fs_hz, [], lambda w: w).warnings


def test_a_mode_between_half_and_the_whole_sample_rate_is_warned_about(case3):
    machine, f = case3
    assert f.size == 6 and 104.0 < f[-1] < 105.0 and f[-2] < 30.0
    fs = 150.0                                                  # f6 in (75, 150) Hz
    assert fs / 2 < f[-1] < fs
    (warning,) = warnings_at(machine, fs)
    assert f"mode 6 at {f[-1]:.4g} Hz" in warning and "150 Hz sample rate" in warning
    assert "and 1 more" not in warning and f"above {2 * f[-1]:.4g} Hz" in warning


def test_modes_below_half_the_sample_rate_are_not_warned_about(case3):
    machine, f = case3
    assert warnings_at(machine, 220.0) == []                   # f6 = 104.7 < 110 Hz
    assert warnings_at(machine, 2.02 * f[-1]) == []


def test_two_modes_above_the_nyquist_frequency_are_both_counted(case3):
    machine, f = case3
    fs = 45.0                                                   # f5 = 24.8 and f6 above 22.5 Hz
    assert f[3] < fs / 2 < f[4]
    (warning,) = warnings_at(machine, fs)
    assert f"mode 5 at {f[4]:.4g} Hz and 1 more up to {f[5]:.4g} Hz" in warning


@dataclass
class Profile:
    """A speed profile's extremes and held speeds (rad/s)."""

    min_speed_rad_s: float
    max_speed_rad_s: float
    held: tuple

    def held_speeds(self):
        return np.array(self.held)


def test_more_held_speeds_than_checked_are_thinned_evenly():
    """Eight speeds, at most six checked: indices round(linspace(0, 7, 6)) = 0 1 3 4 6 7
    (0, 1.4, 2.8, 4.2, 5.6, 7), both extremes among them."""
    hz = np.array([5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0])
    got = scenario_speeds(Profile(TWO_PI * 5.0, TWO_PI * 40.0, tuple(TWO_PI * hz[1:-1])))
    np.testing.assert_allclose(got / TWO_PI, hz[[0, 1, 3, 4, 6, 7]], rtol=1e-15)
    six = scenario_speeds(Profile(TWO_PI * 5.0, TWO_PI * 30.0, tuple(TWO_PI * hz[1:5])))
    np.testing.assert_allclose(six / TWO_PI, hz[:6], rtol=1e-15)       # six: all of them


@dataclass
class Block:
    """A block of a run's time series as the watch reads it."""

    time_s: np.ndarray
    channels: dict
    units: dict


def watch_run(growth_per_s, n=10_000, T=1e-3, chunk=700, rows=None):
    """A channel e^(sigma t) fed in chunks that do not line up with the tenths of the run."""
    rows = rows or [{"speed_hz": 20.0, "freq_hz": 30.0, "damping_ratio": -0.1,
                     "growth_per_s": 20.0},
                    {"speed_hz": 20.0, "freq_hz": 60.0, "damping_ratio": -0.2,
                     "growth_per_s": 50.0}]
    watch = DivergenceWatch(DesignCheck(1 / T, unstable_poles=rows), n)
    t = np.arange(n) * T
    x = np.exp(growth_per_s * t)
    for k in range(0, n, chunk):
        assert watch.feed(Block(t[k:k + chunk], {"x": x[k:k + chunk], "z": 0 * t[k:k + chunk]},
                                {"x": "m", "z": "m"})) is None
    return watch.verdict()


def test_a_growing_run_is_said_with_its_rate_and_the_nearest_unstable_pole():
    """e^(20 t) over 10 s: the largest value of the last tenth over the first tenth's is
    e^(20 * 9 s); between the tenths' mid-times (8.999 s) that is a rate of 20.0 1/s, which
    names the 30 Hz pole (growth 20 1/s), not the faster 60 Hz one."""
    verdict = watch_run(20.0)
    assert verdict.startswith("the run diverged: x grew from")
    assert "m (e^(20 t)) as the unstable closed-loop pole 30 Hz" in verdict
    assert "e^(50 t)) at 20 Hz shaft speed" not in verdict
    assert "60 Hz" in watch_run(50.0)


def test_without_a_rate_the_fastest_growing_pole_is_named():
    check = DesignCheck(1e3, unstable_poles=[
        {"speed_hz": 20.0, "freq_hz": 30.0, "damping_ratio": -0.1, "growth_per_s": 20.0},
        {"speed_hz": 20.0, "freq_hz": 60.0, "damping_ratio": -0.2, "growth_per_s": 50.0}])
    assert check.growing_mode().startswith("60 Hz, damping ratio -0.2 (grows e^(50 t))")
    assert check.growing_mode(25.0).startswith("30 Hz")
    assert DesignCheck(1e3).growing_mode() is None


def test_a_run_that_ends_before_the_middle_of_its_last_tenth_states_no_rate():
    """10 s planned (n = 10000), e^(20 t) fed up to t = 9.4 s only: the last tenth's largest value
    e^(20 * 9.4) against the first's e^(20 * 0.999) is a divergence, but without the last tenth's
    mid-time (9.499 s) no growth rate is measured -- the fastest-growing pole is named."""
    rows = [{"speed_hz": 20.0, "freq_hz": 30.0, "damping_ratio": -0.1, "growth_per_s": 20.0},
            {"speed_hz": 20.0, "freq_hz": 60.0, "damping_ratio": -0.2, "growth_per_s": 50.0}]
    n, T = 10_000, 1e-3
    t = np.arange(9401) * T
    watch = DivergenceWatch(DesignCheck(1 / T, unstable_poles=rows), n)
    assert watch.feed(Block(t, {"x": np.exp(20.0 * t)}, {"x": "m"})) is None
    verdict = watch.verdict()
    assert verdict == (f"the run diverged: x grew from {math.exp(20 * 0.999):.3g} to "
                       f"{math.exp(20 * 9.4):.3g} m as the unstable closed-loop pole 60 Hz, "
                       "damping ratio -0.2 (grows e^(50 t)) at 20 Hz shaft speed")


def test_a_run_shorter_than_ten_samples_has_no_tenths_to_compare():
    rows = [{"speed_hz": 20.0, "freq_hz": 30.0, "damping_ratio": -0.1, "growth_per_s": 20.0}]
    watch = DivergenceWatch(DesignCheck(1e3, unstable_poles=rows), 9)
    t = np.arange(9) * 1e-3
    assert watch.feed(Block(t, {"x": 10.0 ** np.arange(9)}, {"x": "m"})) is None
    assert watch.verdict() is None


def test_growth_below_the_divergence_factor_or_without_unstable_poles_is_no_divergence():
    # e^(sigma 9 s) = 0.9 DIVERGENCE_GROWTH: no verdict; 1.1 times it: diverged
    sigma = math.log(DIVERGENCE_GROWTH) / 9.0
    assert watch_run(sigma + math.log(0.9) / 9.0) is None
    assert watch_run(sigma + math.log(1.1) / 9.0) is not None
    n = 1000
    t = np.arange(n) * 1e-3
    quiet = DivergenceWatch(DesignCheck(1e3), n)               # a stable design
    quiet.feed(Block(t, {"x": np.exp(50.0 * t)}, {"x": "m"}))
    assert quiet.verdict() is None


def test_a_value_that_is_not_finite_is_said_at_once():
    rows = [{"speed_hz": 20.0, "freq_hz": 30.0, "damping_ratio": -0.1, "growth_per_s": 20.0}]
    watch = DivergenceWatch(DesignCheck(1e3, unstable_poles=rows), 100)
    t = np.arange(100) * 1e-3
    x = np.ones(100)
    x[37] = np.inf
    msg = watch.feed(Block(t, {"x": x}, {"x": "m"}))
    assert msg.startswith("the run overflowed: x is inf at t = 0.037 s")
    assert "(the unstable closed-loop pole 30 Hz" in msg


def test_the_watch_takes_exactly_the_first_and_the_last_tenth():
    """Baseline 1 with 1e6 at sample 1000 (just after the first tenth of 10000) and 1e4 at
    sample 9000 (the first of the last tenth): growth 1e4 / 1, diverged; the first tenth's
    largest value is 1, the last's 1e4. Chunks of 500 end exactly at the first mid-time."""
    rows = [{"speed_hz": 20.0, "freq_hz": 30.0, "damping_ratio": -0.1, "growth_per_s": 20.0}]
    n, T = 10_000, 1e-3
    t = np.arange(n) * T
    x = np.ones(n)
    x[1000], x[9000] = 1e6, 1e4
    watch = DivergenceWatch(DesignCheck(1 / T, unstable_poles=rows), n)
    for k in range(0, n, 500):
        assert watch.feed(Block(t[k:k + 500], {"x": x[k:k + 500]}, {"x": "m"})) is None
    assert watch.verdict().startswith("the run diverged: x grew from 1 to 1e+04 m ")


def test_growth_by_exactly_the_divergence_factor_is_a_divergence():
    rows = [{"speed_hz": 20.0, "freq_hz": 30.0, "damping_ratio": -0.1, "growth_per_s": 20.0}]
    t = np.arange(1000) * 1e-3
    x = np.ones(1000)
    x[950] = DIVERGENCE_GROWTH                                 # 1000 x the first tenth's 1
    watch = DivergenceWatch(DesignCheck(1e3, unstable_poles=rows), 1000)
    watch.feed(Block(t, {"x": x}, {"x": "m"}))
    assert watch.verdict().startswith("the run diverged: x grew from 1 to 1e+03 m ")


def test_the_reported_growth_uses_the_exact_tenths():
    """e^(20 t) over 10 s, first tenth up to t = 0.999 s, last tenth up to 9.999 s."""
    verdict = watch_run(20.0)
    assert f"grew from {math.exp(20 * 0.999):.3g} to {math.exp(20 * 9.999):.3g} m" in verdict


def test_small_signals_and_a_start_from_zero():
    """1e-3 e^(sigma t) growing 200 times is no divergence (below DIVERGENCE_GROWTH, whatever
    the scale); a channel zero over the first tenth that reaches 0.5 grew without bound; of two
    channels that grew alike the first is named."""
    rows = [{"speed_hz": 20.0, "freq_hz": 30.0, "damping_ratio": -0.1, "growth_per_s": 20.0}]
    n, T = 1000, 1e-3
    t = np.arange(n) * T
    sigma = math.log(200.0) / 0.9

    def verdict(channels):
        watch = DivergenceWatch(DesignCheck(1 / T, unstable_poles=rows), n)
        watch.feed(Block(t, channels, {k: "m" for k in channels}))
        return watch.verdict()

    assert verdict({"x": 1e-3 * np.exp(sigma * t)}) is None
    late = np.where(t < 0.5, 0.0, 0.5)
    assert verdict({"x": late}).startswith("the run diverged: x grew from 0 to 0.5 m as the")
    grow = np.exp(10.0 * t)                                     # e^(10 * 0.9) = 8103 times
    assert ": b grew" in verdict({"a": np.exp(5.0 * t), "b": grow, "c": grow})


def test_controller_faults_are_summed_up_per_block():
    @dataclass
    class Faulted:
        measurement_limit: float
        faults: dict
        safe_output: str = "hold"

    lines = fault_summary({"DL": Faulted(1e5, {"implausible": 3, "filter_reset": 0}),
                           "DR": Faulted(1e5, {"implausible": 0, "filter_reset": 0}),
                           "NL": Faulted(50.0, {"implausible": 0, "filter_reset": 2}, "zero")})
    assert lines == ["controller DL rejected measurements beyond +-100000 or reset its filter "
                     "(implausible 3; safe output hold)",
                     "controller NL rejected measurements beyond +-50 or reset its filter "
                     "(filter_reset 2; safe output zero)"]


@dataclass
class Plant:
    mass: np.ndarray
    stiffness: np.ndarray


def test_rigid_body_modes_are_left_out_of_the_natural_frequencies():
    """Eigenvalues 0 (a rigid-body mode), 1e-12 (one found so by rounding) and (2 pi 10)^2,
    (2 pi 25)^2 rad^2/s^2: the natural frequencies are 10 and 25 Hz."""
    k = np.diag([0.0, 1e-12, (TWO_PI * 10) ** 2, (TWO_PI * 25) ** 2])
    np.testing.assert_allclose(natural_frequencies_hz(Plant(np.eye(4), k)), [10.0, 25.0],
                               rtol=1e-12)


def test_the_check_states_its_rate_and_keeps_unresolved_speeds_out_of_the_poles(case3):
    machine, _ = case3
    chk = check_design(machine, 1e-12, [TWO_PI * 20.0], lambda w: TWO_PI * 30.0)
    assert chk.sample_rate_hz == pytest.approx(1e12, rel=1e-15)
    assert chk.fatal and "not resolved in double precision" in chk.fatal[0]
    assert chk.unstable_poles == []
    assert check_design(machine, 2e-4, [], lambda w: w).sample_rate_hz == pytest.approx(5000.0)


def test_a_pole_further_than_the_resolution_from_the_unit_circle_is_resolved(case3):
    """At high rates the slowest pole sits at |z| ~ 1 - sigma T (sigma ~ 9.2 1/s for case 3 at
    20 Hz, measured here at 1 MHz): the rate that puts it 1.5e-7 inside the circle is resolved,
    the one that puts it 0.5e-7 inside is not (RESOLUTION = 1e-7)."""
    machine, _ = case3
    speed, w_F = TWO_PI * 20.0, TWO_PI * 30.0
    loop = SampledLoop.from_blocks(machine.plant, build_digital_controllers(machine, 1e-6))
    sigma = float(np.min(np.abs(np.abs(loop.poles(speed, w_F).z) - 1.0))) / 1e-6
    assert 9.0 < sigma < 9.5
    resolved = check_design(machine, 1.5e-7 / sigma, [speed], lambda w: w_F)
    assert resolved.ok and resolved.fatal == []
    unresolved = check_design(machine, 0.5e-7 / sigma, [speed], lambda w: w_F)
    assert "poles within 1e-07 of |z| = 1" in unresolved.fatal[0]
