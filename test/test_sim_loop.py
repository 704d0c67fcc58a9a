"""The in-process lockstep loop: closed-loop steady state against the sampled-loop model of
rotor_avc.analysis.sampled_loop (an independent assembly of the same sampling contract), the
convergence to the continuous closed-loop FRF as the step shrinks, start from rest, the time
series and its file, and a balancer block."""
import numpy as np
import pytest

from rotor_avc.closed_loop.frf import unbalance_frf
from rotor_avc.analysis.sampled_loop import SampledLoop
from rotor_avc.control.block import build_digital_controllers
from rotor_avc.errors import ModelError
from rotor_avc.config import find_config, load_yaml
from rotor_avc.machine import load_machine, machine_from_config
from rotor_avc.sim.loop import control_plan, forces_from_answers, run_loop
from rotor_avc.sim.speed_profile import constant_speed, ramp
from rotor_avc.sim.stepper import PlantStepper
from rotor_avc.sim.timeseries import TimeSeries

TWO_PI = 2 * np.pi
AMP = {"static": 1.0e-2 * np.exp(0.7j), "moment": 2.0e-3 * np.exp(-0.2j)}


def fit(ts, name, t0=0.0):
    """``(Y, residual)``: least-squares 1x phasor of a channel from t0 on, and the largest
    misfit relative to the signal (a transient shows up there)."""
    mask = ts.time_s >= t0
    th, y = ts.angle_rad[mask], ts[name][mask]
    basis = np.column_stack([np.ones_like(th), np.cos(th), np.sin(th)])
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    scale = max(np.abs(y).max(), 1e-300)
    return coef[1] - 1j * coef[2], np.abs(basis @ coef - y).max() / scale


def closed_loop_run(machine, f_hz, fs, n, initial_state="steady_state", amplitudes=AMP):
    speed = TWO_PI * f_hz
    st = PlantStepper(machine.plant, 1 / fs, constant_speed(speed), amplitudes)
    ctrls = build_digital_controllers(machine, 1 / fs)
    return run_loop(st, ctrls, n, initial_state=initial_state), ctrls


def response(frf, quantity, amplitudes):
    return sum(frf.responses[f"{quantity}_{e}"][0] * a for e, a in amplitudes.items())


@pytest.mark.parametrize("config, f_hz", [
    ("foot_mount_case3", 9.4),        # damped machine modes (digest 8.3)
    ("foot_mount_case3", 20.9),       # u_alpha v_bDy peak
    ("foot_mount_case3", 105.1),      # the 104.7 Hz mode on the stiff element
    ("foot_mount_case3", 240.0),
    ("foot_mount_case3_4act", 18.6),  # the yaw mode the vertical actuators cannot damp (R11)
])
def test_closed_loop_steady_state_equals_sampled_loop_model(config, f_hz):
    machine = load_machine(config)
    fs = 5000.0
    ts, ctrls = closed_loop_run(machine, f_hz, fs, 1500)
    model = SampledLoop.from_blocks(machine.plant, ctrls)
    frf = model.unbalance_frf([TWO_PI * f_hz])
    names = [o.name for o in machine.plant.outputs] + [
        f"actuator_{i}_f{ax}" for i, ax in machine.plant.force_points]
    for name in names:
        ref = response(frf, name, AMP)
        got, misfit = fit(ts, name)
        if ref == 0:                                  # NR force: no controller there
            assert not np.any(ts[name]), name
            continue
        # the issue asks 0.1 dB and 1 degree; the two assemblies agree to rounding
        assert abs(got / ref - 1) < 1e-8, name
        assert misfit < 1e-8, name                    # no transient: started on the solution


def test_loop_converges_to_the_continuous_frf_as_the_step_shrinks():
    """Case 3 at 20 Hz: the sampled loop deviates from the continuous FRF by O(T) (one sample
    of feed-through delay and the Tustin integrator); at 50 kHz within 0.1 dB and 1 degree."""
    machine = load_machine("foot_mount_case3")
    f_hz = 20.0
    cont = unbalance_frf(machine.loop, [TWO_PI * f_hz])
    worst = {}
    for fs in (5000.0, 50000.0):
        ts, _ = closed_loop_run(machine, f_hz, fs, int(fs * 0.1))
        dev = []
        for name in ("bearing_D_vz", "bearing_N_vy", "foundation_DL_vz", "actuator_DL_fz"):
            got, _ = fit(ts, name)
            ratio = got / response(cont, name, AMP)
            dev.append(max(abs(20 * np.log10(abs(ratio))) / 0.1, abs(np.angle(ratio, deg=True))))
        worst[fs] = max(dev)
    assert worst[50000.0] < 1.0                         # 0.1 dB and 1 degree
    assert worst[50000.0] < 0.2 * worst[5000.0]         # first order in T


def test_start_from_rest_settles_on_the_steady_state():
    machine = load_machine("foot_mount_case3")
    f_hz, fs = 20.9, 2000.0
    ts, ctrls = closed_loop_run(machine, f_hz, fs, int(fs * 4.0), initial_state="rest")
    ref = response(SampledLoop.from_blocks(machine.plant, ctrls).unbalance_frf([TWO_PI * f_hz]),
                   "bearing_D_vy", AMP)
    got, _ = fit(ts, "bearing_D_vy", t0=3.0)
    assert abs(got / ref - 1) < 1e-6        # the slowest closed-loop mode decays at ~8 1/s
    early, _ = fit(ts, "bearing_D_vy", t0=0.0)
    assert abs(early / ref - 1) > 1e-3      # ... and the start from rest is visibly transient


def test_extra_delay_starts_without_transient():
    data = load_yaml(find_config("foot_mount_case3"))
    for sec in data["controllers"].values():
        sec["delay_samples"] = 2
    machine = machine_from_config(data, "case 3 with two delay samples")
    ts, ctrls = closed_loop_run(machine, 30.0, 5000.0, 800)
    assert all(c.delay_samples == 2 for c in ctrls.values())
    ref = response(SampledLoop.from_blocks(machine.plant, ctrls).unbalance_frf([TWO_PI * 30.0]),
                   "actuator_DL_fz", AMP)
    got, misfit = fit(ts, "actuator_DL_fz")
    assert abs(got / ref - 1) < 1e-8 and misfit < 1e-8


def test_time_series_content_and_file(tmp_path):
    machine = load_machine("foot_mount_case3")
    fs = 5000.0
    st = PlantStepper(machine.plant, 1 / fs, ramp(TWO_PI * 10, TWO_PI * 12, 0.05), AMP)
    ctrls = build_digital_controllers(machine, 1 / fs)
    ts = run_loop(st, ctrls, 250, metadata={"note": "test"})
    assert len(ts) == 250
    np.testing.assert_allclose(ts.time_s, np.arange(250) / fs)
    np.testing.assert_allclose(ts.speed_rad_s[[0, -1]], TWO_PI * np.array([10, 10 + 2 * 249 / 250]))
    assert np.all(ts.accel_rad_s2 == pytest.approx(TWO_PI * 40))
    assert not np.any(ts["actuator_NR_fz"])           # stiff element, no controller
    # the recorded force answers the recorded measurement: replay the controllers on it
    for ctrl in ctrls.values():
        ctrl.reset()
    replay = [ctrls["DL"].step(a) for a in ts["foot_DL_az"]]
    np.testing.assert_allclose(ts["actuator_DL_fz"], replay, rtol=1e-12, atol=1e-12)
    assert ts.units["foot_DL_az"] == "m/s^2" and ts.units["actuator_DL_fz"] == "N"
    path = ts.save(tmp_path / "run.npz")
    back = TimeSeries.load(path)
    assert back.metadata["note"] == "test" and back.metadata["plant"] == "foot_mount_case3"
    assert back.units == ts.units and set(back.channels) == set(ts.channels)
    for name in ts.channels:
        np.testing.assert_array_equal(back[name], ts[name])
    np.testing.assert_array_equal(back.angle_rad, ts.angle_rad)
    raw = np.load(path)                               # plain numpy reads it too
    np.testing.assert_array_equal(raw["ch:bearing_D_vz"], ts["bearing_D_vz"])
    with pytest.raises(ModelError, match=".npz"):
        ts.save(tmp_path / "run.csv")


class CancelAfter:
    """A stand-in balancer: after t_on, correct the static unbalance exactly."""

    def __init__(self, t_on, amplitude):
        self.t_on, self.amplitude = t_on, amplitude
        self.seen = []

    def reset(self):
        self.seen = []

    def step(self, sample):
        self.seen.append((sample.k, sample.t, sample.speed, sample.angle))
        return {"static": -self.amplitude} if sample.t >= self.t_on else None


def test_balancer_block_in_the_loop():
    """A balancer that cancels the static unbalance at 0.2 s: it sees every sample (time, speed,
    angle as recorded), its correction is recorded and applied from the next step, and the
    bearing vibration of the case-3 machine dies out (its slowest mode decays at >= 8 1/s)."""
    machine = load_machine("foot_mount_case3")
    fs = 2000.0
    st = PlantStepper(machine.plant, 1 / fs, constant_speed(TWO_PI * 20), {"static": 1e-2})
    bal = CancelAfter(0.2, 1e-2)
    ts = run_loop(st, build_digital_controllers(machine, 1 / fs), 3000, balancer=bal,
                  initial_state="steady_state")
    k, t, speed, angle = np.array(bal.seen).T
    np.testing.assert_array_equal(k, np.arange(3000))
    np.testing.assert_allclose(t, ts.time_s, rtol=1e-14)
    np.testing.assert_allclose(speed, ts.speed_rad_s, rtol=1e-14)
    np.testing.assert_allclose(angle, ts.angle_rad, rtol=1e-14)
    on = ts.time_s >= 0.2
    np.testing.assert_array_equal(ts["balancer_static_re"][on], -1e-2)
    assert not np.any(ts["balancer_static_re"][~on]) and not np.any(ts["balancer_moment_im"])
    first = np.flatnonzero(on)[0]
    before = ts["bearing_D_vz"][:first + 1]           # y at the switching sample is unchanged
    np.testing.assert_allclose(before[-1], before[-1 - int(fs / 20)], rtol=1e-9)
    late = ts.time_s >= 1.4
    early = ts.time_s < 0.2
    assert np.abs(ts["bearing_D_vz"][late]).max() < 1e-3 * np.abs(ts["bearing_D_vz"][early]).max()


def test_plan_errors():
    machine = load_machine("foot_mount_case3")
    ctrls = build_digital_controllers(machine, 1 / 5000)
    st = PlantStepper(machine.plant, 1 / 4000, constant_speed(10.0), {})
    with pytest.raises(ModelError, match="lockstep needs one rate"):
        control_plan(st, ctrls)
    st = PlantStepper(load_machine("foot_mount_case2").plant, 1 / 5000, constant_speed(10.0), {})
    with pytest.raises(ModelError, match="plant's actuators"):
        control_plan(st, {"XX": ctrls["DL"]})
    with pytest.raises(ModelError, match="at least one sample"):
        run_loop(st, {}, 0)
    with pytest.raises(ModelError, match="initial state"):
        run_loop(st, {}, 5, initial_state="warm")


def test_per_step_functions_reproduce_the_loop():
    """What a ROS graph does -- the plant steps on forces collected by actuator id from foot
    nodes that each step their own controller on their foot's signal -- gives the loop's run."""
    machine = load_machine("foot_mount_case3")
    fs = 5000.0
    profile = ramp(TWO_PI * 15, TWO_PI * 25, 0.1)
    ts = run_loop(PlantStepper(machine.plant, 1 / fs, profile, AMP),
                  build_digital_controllers(machine, 1 / fs), 400)
    st = PlantStepper(machine.plant, 1 / fs, profile, AMP)
    ctrls = build_digital_controllers(machine, 1 / fs)
    y = st.reset()
    forces, bearing = [], []
    for _ in range(400):
        bearing.append(y[st.layout.index("bearing_N_vz")])
        answers = {foot: ctrl.step(float(y[st.layout.index(f"foot_{foot}_az")]))
                   for foot, ctrl in ctrls.items()}
        forces.append(answers["NL"])
        y = st.step(forces_from_answers(st, answers))
    np.testing.assert_array_equal(forces, ts["actuator_NL_fz"])
    np.testing.assert_array_equal(bearing, ts["bearing_N_vz"])
    with pytest.raises(ModelError, match="plant's actuators"):
        forces_from_answers(st, {"XY": 1.0})
