"""The adaptive harmonic block (rotor_avc.harmonic.block) through the forces it returns and the
states it switches between, each against a hand computation:

* the forces are ``u_k = sum_h Re{A_h e^{j h theta_k}}``: on a static plant driven by the returned
  forces (``y_k = Re{P_1 e^{j theta}} + Re{P_2 e^{2j theta}} + G0 u_{k-1}``, whose influence at
  harmonic ``h`` is ``G0 e^{-j h Omega T}`` for the one-sample hold), 1x and 2x cancel to
  rounding;
* off before ``start_s`` (to the sample), at and above ``min_speed_hz``, inside the influence
  schedule only (also when the schedule starts above ``min_speed_hz``); switched on again it
  starts from zero phasors and an empty window (the first update demodulates the new signal
  alone);
* adapting in the excitations, the phasors follow ``U = -pinv(G(Omega)) H(Omega) C`` every
  ``refresh_samples`` samples between updates;
* a fallback fades phasors and estimate by ``1 - 1/fade_updates`` per update: after
  ``fade_updates`` = 10 updates to ``0.9^10 = 0.349`` (about e^-1);
* the identification dither has the amplitude ``dither_n`` and a phase spread over the circle;
* the supervisor's re-identified matrix is the estimate the law then uses (the plant's own,
  measured with test phasors on an exact static plant);
* integer settings below their minimum, and other settings out of range, are refused naming
  the setting; a block made without a configuration has the configuration's defaults; the gain
  schedule takes the nearest node in log speed;
* a limit that does not bind reports no saturation (also for an actuator whose phasor is zero);
* online identification learns the plant's influence from the changes of phasors and error
  (from a prior 30 % and 25 degrees off, with the dither), and with the dither's response
  ``G^ D`` taken out of the error the phasors cancel the disturbance (``p + g U = 0``);
* switched on again, the supervisor measures the level with control off again.
"""
import copy
import dataclasses
import math

import numpy as np
import pytest

from rotor_avc.config import load_config
from rotor_avc.errors import ModelError
from rotor_avc.harmonic.block import HarmonicController
from rotor_avc.harmonic.block_settings import HarmonicSettings
from rotor_avc.harmonic.influence import InfluenceSchedule
from rotor_avc.harmonic.supervisor import SupervisorSettings
from rotor_avc.scenario import scenario_from_config

T = 1e-3
HZ = 10.0
SPEED = 2 * math.pi * HZ                  # 100 samples per revolution
RNG = np.random.default_rng(5)
G0 = RNG.standard_normal((2, 3))          # a static (real) plant, 2 sensors x 3 actuators
OFF = SupervisorSettings(enabled=False)


def settings(**keys):
    keys.setdefault("supervisor", OFF)
    return HarmonicSettings(**{"min_speed_hz": 1.0, **keys})


def schedule(matrices, speeds_hz=(5.0, 20.0), harmonics=(1,), disturbance=None):
    """The same matrices (H, M, N) at every speed of the schedule."""
    speeds = 2 * math.pi * np.asarray(speeds_hz, dtype=float)
    m, n = matrices.shape[1:]
    d = None if disturbance is None else np.stack([disturbance] * speeds.size)
    return InfluenceSchedule(speeds, tuple(harmonics), np.stack([matrices] * speeds.size),
                             tuple(f"s{i}" for i in range(m)), tuple(f"a{i}" for i in range(n)),
                             d, ("unbalance",) if d is not None else ())


def test_1x_and_2x_cancel_through_the_returned_forces():
    p1, p2 = np.array([0.3 + 0.2j, -0.1j]), np.array([0.05, 0.02 - 0.04j])
    held = np.stack([G0 * np.exp(-1j * h * SPEED * T) for h in (1, 2)])
    block = HarmonicController(schedule(held, harmonics=(1, 2)), T,
                               settings(gain=0.8, update_every_samples=100))
    u, ys = np.zeros(3), []
    for k in range(6000):
        angle = SPEED * k * T
        y = (p1 * np.exp(1j * angle) + p2 * np.exp(2j * angle)).real + G0 @ u
        u = np.asarray(block.step(list(y), angle, SPEED))
        ys.append(y)
    assert np.abs(ys[0]).max() > 0.1
    assert np.abs(ys[-100:]).max() < 1e-9
    # the last force by hand: sum_h Re{A_h e^{j h theta}}
    theta = SPEED * T * 5999
    A = block.U + block.D
    by_hand = sum((A[i] * np.exp(1j * h * theta)).real for i, h in enumerate((1, 2)))
    np.testing.assert_allclose(u, by_hand, atol=1e-12)


def open_loop(block, hz_of_k, phasor_of_k, n):
    """Step the block on ``y = Re{P e^{j theta}}`` (its forces not fed back): forces, modes."""
    forces, modes, angle = [], [], 0.0
    for k in range(n):
        speed = 2 * math.pi * hz_of_k(k)
        y = (phasor_of_k(k) * np.exp(1j * angle)).real
        forces.append(block.step(list(y), angle, speed))
        modes.append(block.mode)
        angle += speed * T
    return np.array(forces), modes


G1 = np.array([[[1.0 + 0.5j]]])
P = np.array([0.8 - 0.3j])


@pytest.mark.parametrize("period_s, start_s, first", [
    (T, 0.05, 50),                     # t_50 = 0.05 s
    (1 / 3000, 0.017, 51)])            # t_51 = 0.017 s, though 0.017 / (1/3000) = 51.00000000000001
def test_off_before_start_s_to_the_sample(period_s, start_s, first):
    block = HarmonicController(schedule(G1), period_s, settings(start_s=start_s,
                                                                update_every_samples=100))
    forces, modes = [], []
    for k in range(first + 300):
        angle = SPEED * k * period_s
        forces.append(block.step([(P * np.exp(1j * angle)).real[0]], angle, SPEED))
        modes.append(block.mode)
    assert set(modes[:first]) == {"off"} and set(modes[first:]) == {"adapting"}
    forces = np.array(forces)
    assert not forces[:first + 99].any()          # zero phasors until the first update
    assert np.abs(forces[first + 99:]).max() > 0.1


def test_a_revolution_of_40_samples_is_one_update_window():
    """25 Hz at 1 kHz: the angle steps of 40 samples add up to one revolution; an update at
    every 40th sample, the window's phasor the disturbance's exactly."""
    speed = 2 * math.pi * 25.0
    block = HarmonicController(schedule(G1, (5.0, 30.0)), T, settings(gain=1e-9))
    updates = []
    for k in range(120):
        angle = speed * k * T
        block.step([(P * np.exp(1j * angle)).real[0]], angle, speed)
        updates.append(block.n_updates)
    assert [k for k in range(1, 120) if updates[k] != updates[k - 1]] == [39, 79, 119]
    np.testing.assert_allclose(block.E[0], P, atol=1e-12)


def test_a_non_finite_signal_is_refused_naming_its_sensor():
    block = HarmonicController(schedule(np.ones((1, 3, 1), complex)), T,
                               settings(update_every_samples=10))
    for k in range(9):
        block.step([0.1, np.nan if k == 4 else 0.2, 0.3], 0.1 * k, SPEED)
    with pytest.raises(ModelError, match=r"harmonic: non-finite signal of s1 in the last window"):
        block.step([0.1, 0.2, 0.3], 0.9, SPEED)


def test_a_schedule_of_one_speed_serves_that_speed():
    one = InfluenceSchedule(np.array([SPEED]), (1,), G1[None], ("s0",), ("a0",))
    block = HarmonicController(one, T, settings(gain=1.0))
    g = G1[0, 0]
    for k in range(1000):
        angle = SPEED * k * T
        block.step([((P + g @ block.U[0]) * np.exp(1j * angle)).real[0]], angle, SPEED)
    assert block.mode == "adapting" and np.abs(P + g @ block.U[0]).max() < 1e-9


def test_a_state_of_another_shape_or_mode_is_refused():
    two = HarmonicController(schedule(np.ones((1, 1, 2), complex)), T, settings())
    one = HarmonicController(schedule(G1), T, settings())
    unknown = dict(one.state, mode="exploded")
    for state in (two.state, unknown):
        with pytest.raises(ModelError, match="harmonic state does not fit 1 harmonics x 1 "
                                             "sensors x 1 actuators"):
            one.set_state(state)
    one.set_state(dict(one.state, mode="frozen"))
    assert one.mode == "frozen"


@pytest.mark.parametrize("min_hz, sched_hz, low_hz", [
    (5.0, (5.0, 20.0), 4.0),          # below min_speed_hz
    (2.0, (5.0, 20.0), 4.0),          # above min_speed_hz, below the schedule's first speed
    (2.0, (5.0, 20.0), 21.0)])        # above the schedule's last speed
def test_on_from_min_speed_inside_the_schedule_only(min_hz, sched_hz, low_hz):
    block = HarmonicController(schedule(G1, sched_hz), T, settings(min_speed_hz=min_hz))
    first = sched_hz[0]                       # exactly at the lowest speed it runs at
    forces, modes = open_loop(block, lambda k: first if k < 300 else low_hz, lambda k: P, 400)
    assert set(modes[:300]) == {"adapting"} and np.abs(forces[200:300]).max() > 0.1
    assert set(modes[300:]) == {"off"} and not forces[300:].any()
    assert block.reason == "below min_speed_hz or outside the schedule"


def test_switched_on_again_it_starts_from_zero_phasors_and_an_empty_window():
    p_new = np.array([-0.2 + 0.6j])
    block = HarmonicController(schedule(G1), T, settings(min_speed_hz=5.0, gain=0.5,
                                                         update_every_samples=100))
    # on at 10 Hz (an update at sample 99, half the next window filled), off at 3 Hz for 20
    # samples, on again at 10 Hz with another disturbance: its first update at sample 269
    forces, modes = open_loop(block, lambda k: 3.0 if 150 <= k < 170 else HZ,
                              lambda k: P if k < 150 else p_new, 270)
    assert np.abs(forces[100:150]).max() > 0.1 and modes[150:170] == ["off"] * 20
    assert modes[170] == "adapting" and not forces[170:269].any()   # no update since: zero
    # the first update after switching on: the new disturbance's phasor alone
    assert block.n_updates == 2
    np.testing.assert_allclose(block.E[0], p_new, atol=1e-12)


def test_switched_off_in_the_excitations_the_estimate_starts_again_from_zero():
    g, h = np.array([[1.0 + 0.5j]]), np.array([[2.0 - 1.0j]])
    c_true = np.array([0.5 + 0.5j])

    def block():
        return HarmonicController(schedule(g[None], disturbance=h), T, settings(
            adapt_in="excitations", min_speed_hz=5.0, update_every_samples=100))

    used = block()
    open_loop(used, lambda k: 3.0 if k >= 300 else HZ, lambda k: h @ c_true, 320)
    assert used.mode == "off" and not used.C.any() and not used.U.any()
    assert used.status["excitation_estimate"] == {"unbalance": [0.0, 0.0]}
    fresh = block()
    for b in (used, fresh):
        open_loop(b, lambda k: HZ, lambda k: h @ c_true, 100)
    assert used.n_updates == 4 and fresh.n_updates == 1
    np.testing.assert_allclose(used.C, fresh.C, rtol=1e-12)


def test_in_the_excitations_the_phasors_follow_the_speed_every_refresh():
    g_lo, g_hi = np.array([[1.0 + 0.5j], [0.3 - 0.2j]]), np.array([[0.5 - 1.0j], [0.8 + 0.1j]])
    h_lo, h_hi = np.array([[2.0 + 1.0j], [-1.0 + 0.5j]]), np.array([[0.4 - 2.0j], [1.5 + 0.2j]])
    sched = InfluenceSchedule(2 * math.pi * np.array([8.0, 12.0]), (1,),
                              np.stack([g_lo[None], g_hi[None]]), ("s0", "s1"), ("a0",),
                              np.stack([h_lo, h_hi]), ("unbalance",))
    block = HarmonicController(sched, T, settings(adapt_in="excitations", refresh_samples=10,
                                                  update_every_samples=100))
    c_true = np.array([0.7 - 0.4j])
    # one update at 8 Hz, then 12 Hz: 9 samples hold the phasors, the 10th refreshes them
    open_loop(block, lambda k: 8.0, lambda k: h_lo @ c_true, 100)
    c = block.C.copy()
    assert np.abs(c).max() > 0
    np.testing.assert_allclose(block.U[0], -np.linalg.pinv(g_lo) @ h_lo @ c, atol=1e-12)
    open_loop(block, lambda k: 12.0, lambda k: h_hi @ c_true, 9)
    np.testing.assert_allclose(block.U[0], -np.linalg.pinv(g_lo) @ h_lo @ c, atol=1e-12)
    angle = 0.3
    force = block.step(list((h_hi @ c_true * np.exp(1j * angle)).real), angle, 2 * math.pi * 12)
    np.testing.assert_allclose(block.C, c, atol=0)
    u = -np.linalg.pinv(g_hi) @ h_hi @ c
    np.testing.assert_allclose(block.U[0], u, atol=1e-12)
    np.testing.assert_allclose(force, (u * np.exp(1j * angle)).real, atol=1e-12)   # sent at once


@pytest.mark.parametrize("adapt_in", ["forces", "excitations"])
def test_a_fallback_fades_phasors_and_estimate_in_about_fade_updates(adapt_in):
    g = np.array([[1.0 + 0.5j]])
    h = np.array([[2.0 - 1.0j]])
    wrong = schedule(-g[None], disturbance=h if adapt_in == "excitations" else None)
    block = HarmonicController(wrong, T, settings(adapt_in=adapt_in, gain=0.5,
                                                  divergence_factor=1.5, fade_updates=10,
                                                  update_every_samples=100))
    c_true = np.array([0.5 + 0.5j])
    U, C = [], []
    for k in range(4000):
        angle = SPEED * k * T
        y = (((h @ c_true) + g @ block.U[0]) * np.exp(1j * angle)).real
        before = block.n_updates
        block.step(list(y), angle, SPEED)
        if block.n_updates != before and block.mode == "fading":
            U.append(abs(block.U[0, 0]))
            C.append(abs(block.C[0]) if adapt_in == "excitations" else 1.0)
    assert "diverging" in block.reason and len(U) > 12
    for series in (U, C) if adapt_in == "excitations" else (U,):
        s = np.asarray(series)
        assert np.all(np.diff(s) < 0)
        # 10 updates after the first fading one: (1 - 1/10)^10 = 0.349 of it
        assert s[10] / s[0] == pytest.approx(0.9 ** 10, rel=1e-9)


def test_the_dither_is_drawn_from_its_seed():
    """``D = dither_n e^{2 pi j r}``, ``r`` the uniform draws of numpy's default_rng(seed), one
    (harmonic, actuator) array per update: the same dither on every run of one seed."""
    two = np.ones((2, 1, 2), complex)
    block = HarmonicController(schedule(two, harmonics=(1, 2)), T, settings(
        identify=True, dither_n=0.02, seed=11, update_every_samples=100))
    rng = np.random.default_rng(11)
    for update in range(3):
        open_loop(block, lambda k: HZ, lambda k: np.zeros(1), 100)
        assert block.n_updates == update + 1
        np.testing.assert_allclose(block.D, 0.02 * np.exp(2j * np.pi * rng.random((2, 2))),
                                   rtol=1e-12)


def test_the_dither_has_its_amplitude_and_a_phase_spread_over_the_circle():
    block = HarmonicController(schedule(G1), T, settings(identify=True, dither_n=0.02,
                                                         update_every_samples=100))
    phases = []
    angle = 0.0
    for k in range(6400):
        y = (P * np.exp(1j * angle)).real
        before = block.n_updates
        block.step(list(y), angle, SPEED)
        if block.n_updates != before:
            assert abs(block.D[0, 0]) == pytest.approx(0.02, rel=1e-12)
            phases.append(np.angle(block.D[0, 0]))
        angle += SPEED * T
    quadrants = np.floor(np.mod(phases, 2 * np.pi) / (np.pi / 2)).astype(int)
    assert len(phases) == 64 and set(quadrants) == {0, 1, 2, 3}
    assert abs(np.mean(np.exp(1j * np.array(phases)))) < 0.3


def test_the_supervisors_re_identified_matrix_is_the_estimate_the_law_uses():
    g = np.array([[1.0 + 0.5j, -0.3 + 0.2j], [0.4 - 0.8j, 0.9 + 0.1j]])
    p = np.array([0.6 - 0.2j, -0.3 + 0.5j])
    wrong = schedule(g[None] * np.exp(1j * np.radians(150.0)))
    block = HarmonicController(wrong, T, HarmonicSettings(min_speed_hz=1.0, gain=0.5,
                                                          update_every_samples=100))
    identified = None
    for k in range(30_000):
        angle = SPEED * k * T
        y = ((p + g @ block.U[0]) * np.exp(1j * angle)).real
        block.step(list(y), angle, SPEED)
        if identified is None and "re-identified" in block.reason:
            identified = block.estimate[0].copy()
    assert block.supervisor.fallbacks >= 1 and identified is not None
    np.testing.assert_allclose(identified, g, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(block.estimate[0], g, rtol=1e-9, atol=1e-12)
    assert np.abs(p + g @ block.U[0]).max() < 1e-9       # and the loop converged on it


@pytest.mark.parametrize("name, value", [("patience", 0), ("fade_updates", 0),
                                         ("update_every_samples", -1), ("refresh_samples", -1)])
def test_integer_settings_below_their_minimum_are_refused(name, value):
    low = 1 if name in ("patience", "fade_updates") else 0
    with pytest.raises(ModelError, match=rf"{name} must be an integer >= {low}"):
        HarmonicSettings(**{name: value}).check()


@pytest.fixture(scope="module")
def dynamic():
    """The dynamic feed-forward of Werner 2021 case 2 for a run at 25 Hz (1 kHz), on from
    0.02 s."""
    data = copy.deepcopy(load_config("scenario_harmonic_dynamic_runup").data)
    data["simulation"].update(duration_s=1.0, speed={"type": "constant", "speed_hz": 25.0},
                              initial_state="rest", sample_rate_hz=1000.0)
    data["harmonic"].update(min_speed_hz=24.0, start_s=0.02)
    scen = scenario_from_config(data, "start")
    assert scen.sample_period_s == T
    return scen.harmonic()


@pytest.mark.parametrize("every", [0, 50])
def test_the_dynamic_feedforward_is_off_before_start_s_and_updates_per_window(dynamic, every):
    """Off for the samples before 0.02 s; then an update at the last sample of each window:
    a revolution at 25 Hz is 1000 / 25 = 40 samples, or ``update_every_samples``."""
    block = type(dynamic)(dynamic.schedule, T, dataclasses.replace(
        dynamic.settings, update_every_samples=every), dynamic._loop.tables)
    speed = 2 * math.pi * 25.0
    modes, updates = [], []
    for k in range(20 + 100):
        block.step([0.0] * len(block.sensors), speed * k * T, speed)
        modes.append(block.mode)
        updates.append(block.n_updates)
    assert set(modes[:20]) == {"off"} and set(modes[20:]) == {"adapting"}
    window = every or 40
    assert updates[20 + window - 2] == 0 and updates[20 + window - 1] == 1
    assert updates[20 + 2 * window - 1] == 2


def test_a_block_made_without_a_configuration_has_the_configurations_defaults():
    """Every setting of HarmonicSettings() is the documented default of the ``harmonic:``
    section (rotor_avc.harmonic.config), identification present with its defaults."""
    import dataclasses

    from rotor_avc.harmonic.config import _block_settings, harmonic_section
    from rotor_avc.section import Section
    declared = _block_settings(harmonic_section(Section({"harmonic": {
        "sensors": ["s0"], "identification": {}}}, "defaults")))
    plain = HarmonicSettings()
    differ = [f.name for f in dataclasses.fields(HarmonicSettings)
              if getattr(declared, f.name) != getattr(plain, f.name)]
    assert differ == ["identify"]


def test_the_gain_schedule_takes_the_nearest_node_in_log_speed():
    s = HarmonicSettings(gain_speeds_rad_s=(10.0, 100.0), gain_values=(0.2, 0.8))
    s.check()
    block = HarmonicController(schedule(G1), T, s)
    # log(30 / 10) = 1.10 < log(100 / 30) = 1.20; log(33 / 10) = 1.19 > log(100 / 33) = 1.11
    assert block.gain_at(30.0) == 0.2 and block.gain_at(33.0) == 0.8
    assert HarmonicController(schedule(G1), T, HarmonicSettings(gain=0.3)).gain_at(30.0) == 0.3


@pytest.mark.parametrize("keys, message", [
    ({"gain_speeds_rad_s": (10.0, 100.0), "gain_values": (0.2,)}, "as many speeds as gains"),
    ({"gain_speeds_rad_s": (10.0,), "gain_values": (-0.2,)}, "as many speeds as gains"),
    ({"min_speed_hz": 0.0}, "min_speed_hz must be > 0"),
    ({"start_s": -1.0}, "start_s and dither_n >= 0"),
    ({"dither_n": -1e-3}, "start_s and dither_n >= 0")])
def test_settings_out_of_range_are_refused(keys, message):
    with pytest.raises(ModelError, match=message):
        HarmonicSettings(**keys).check()


def test_a_limit_that_does_not_bind_reports_no_saturation():
    # the third actuator does not reach the sensors: its phasor stays exactly zero
    g = np.array([[1.0 + 0.5j, 0.3j, 0.0], [0.2, -0.7 + 0.1j, 0.0]])
    p = np.array([0.3 - 0.1j, 0.2j])
    block = HarmonicController(schedule(g[None]), T, settings(force_limit_n=100.0,
                                                              rate_limit_n_per_s=1e5))
    for k in range(2000):
        angle = SPEED * k * T
        y = ((p + g @ block.U[0]) * np.exp(1j * angle)).real
        block.step(list(y), angle, SPEED)
    assert block.U[0, 2] == 0 and np.abs(block.U[0, :2]).max() > 0.1
    assert block.status["saturated"] is False and block.status["fallbacks"] == 0
    assert np.abs(p + g @ block.U[0]).max() < 1e-6


def test_online_identification_learns_the_influence_from_the_changes():
    g = np.array([[1.0 + 0.5j, -0.3 + 0.2j], [0.4 - 0.8j, 0.9 + 0.1j]])
    p = np.array([0.6 - 0.2j, -0.3 + 0.5j])
    prior = g * 1.3 * np.exp(1j * np.radians(25.0))
    block = HarmonicController(schedule(prior[None]), T, settings(
        identify=True, dither_n=0.05, forgetting=0.95, min_rel_change=0.0, update_every_samples=100,
        gain=0.3))
    for k in range(20_000):
        angle = SPEED * k * T
        y = ((p + g @ (block.U[0] + block.D[0])) * np.exp(1j * angle)).real
        block.step(list(y), angle, SPEED)
    assert np.abs(prior - g).max() > 0.3
    np.testing.assert_allclose(block.estimate[0], g, atol=1e-6)
    # the dither's own response G^ D is taken out of E before the law acts: the phasors cancel
    # the disturbance (Newton's fixed point p + g U = 0) though the dither keeps changing
    assert np.abs(p + g @ block.U[0]).max() < 1e-7


def test_switched_on_again_the_supervisor_measures_the_level_with_control_off_again():
    """On at 10 Hz, off below min_speed_hz, on again with a disturbance ten times larger: the
    supervisor takes the new level as the one with control off and the loop adapts (with the
    old level it would fall back at once: 20 dB above off)."""
    g = np.array([[1.0 + 0.5j]])
    block = HarmonicController(schedule(g[None]), T, HarmonicSettings(
        min_speed_hz=5.0, gain=0.5, update_every_samples=100))
    p = lambda k: np.array([0.1 + 0.1j]) if k < 2000 else np.array([1.0 + 1.0j])    # noqa: E731
    angle = 0.0
    for k in range(6000):
        hz = 3.0 if 2000 <= k < 2050 else HZ
        y = ((p(k) + g @ block.U[0]) * np.exp(1j * angle)).real
        block.step(list(y), angle, 2 * math.pi * hz)
        angle += 2 * math.pi * hz * T
    assert block.supervisor.fallbacks == 0 and block.mode == "adapting"
    assert np.abs(p(6000) + g @ block.U[0]).max() < 1e-9
