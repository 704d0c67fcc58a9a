"""The DigitalController block and its construction from a machine config."""
import math

import numpy as np
import pytest
import scipy.signal
import yaml

from rotor_avc.config import find_config
from rotor_avc.control.block import DigitalController, build_digital_controllers
from rotor_avc.control.discretize import discretize_controller
from rotor_avc.control.spec import i_controller, pd_controller
from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.machine import load_machine


def _machine(tmp_path, extra: dict):
    cfg = {"include": str(find_config("foot_mount_case3.yaml").resolve())}
    cfg.update(extra)
    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return load_machine(path)


def test_case3_blocks_from_config_defaults():
    machine = load_machine("foot_mount_case3")
    blocks = build_digital_controllers(machine)
    assert list(blocks) == ["DL", "DR", "NL"]            # NR has no controller
    b = blocks["DL"]
    assert b.sample_period_s == 1 / 5000.0 and b.feedback == "acceleration"
    np.testing.assert_allclose(b.tf.b, [14.0, 14.0])      # b0 T / 2, Tustin
    # Werner 2021 eq. 7, f = -G_c a: a positive acceleration step gives a negative force ramp
    forces = [b.step(1.0) for _ in range(3)]
    np.testing.assert_allclose(forces, [-14.0, -42.0, -70.0])


def test_config_settings_and_runtime_keys(tmp_path):
    machine = _machine(tmp_path, {
        "control": {"sample_rate_hz": 2000.0, "method": "tustin", "prewarp_hz": 100.0},
        "controllers": {"DL": {"force_limit_n": 50.0, "anti_windup": "back_calculation",
                               "back_calculation_gain": 100.0, "delay_samples": 2,
                               "rate_limit_n_per_s": 1e6}}})
    blocks = build_digital_controllers(machine)
    dl, dr = blocks["DL"], blocks["DR"]
    ref = discretize_controller(i_controller(1.4e5, "acceleration"), 1 / 2000.0, "tustin", 100.0)
    np.testing.assert_allclose(dl.tf.b, ref.b, rtol=1e-14)
    assert dl.delay_samples == 2 and dr.delay_samples == 0
    assert dl.limits.force_limit_n == 50.0 and math.isinf(dr.limits.force_limit_n)
    assert dl.anti_windup == "back_calculation" and "anti-windup" in dl.describe()
    assert "rate limit 1e+06 N/s" in dl.describe() and "rate limit" not in dr.describe()
    # the sample period argument overrides the config's rate
    assert build_digital_controllers(machine, 1e-4)["DL"].sample_period_s == 1e-4


@pytest.mark.parametrize("extra,field", [
    ({"control": {"sample_rate_hz": -5000.0}}, "control.sample_rate_hz"),
    ({"control": {"sample_rate_hz": float("nan")}}, "control.sample_rate_hz"),
    ({"control": {"method": "euler"}}, "control.method"),
    ({"control": {"prewarp_hz": 3000.0}}, "control.prewarp_hz"),          # Nyquist 2500 Hz
    ({"control": {"method": "zoh", "prewarp_hz": 10.0}}, "control.prewarp_hz"),
    ({"control": {"rate_hz": 5000.0}}, "control.rate_hz"),
    ({"controllers": {"DL": {"delay_samples": -1}}}, "controllers.DL.delay_samples"),
    ({"controllers": {"DL": {"delay_samples": 1.5}}}, "controllers.DL.delay_samples"),
    ({"controllers": {"DL": {"force_limit_n": -10.0}}}, "controllers.DL.force_limit_n"),
    ({"controllers": {"DL": {"anti_windup": "clamp"}}}, "controllers.DL.anti_windup"),
    ({"controllers": {"DL": {"anti_windup": "back_calculation"}}}, "controllers.DL.anti_windup"),
    ({"controllers": {"DL": {"force_limit_n": 10.0, "anti_windup": "back_calculation",
                             "back_calculation_gain": 1e5}}},
     "controllers.DL.back_calculation_gain"),
])
def test_bad_config_names_the_field(tmp_path, extra, field):
    with pytest.raises(ConfigError) as info:
        build_digital_controllers(_machine(tmp_path, extra))
    assert info.value.field == field, str(info.value)


def test_improper_controller_is_refused_when_built(tmp_path):
    machine = load_machine("foot_mount_case3")
    machine.controllers["DL"] = pd_controller(1e6, 1e3, "displacement")   # ideal derivative
    with pytest.raises(ConfigError, match="improper.*derivative filter"):
        build_digital_controllers(machine)


def test_bad_sample_period_argument():
    machine = load_machine("foot_mount_case3")
    for T in (-1e-3, 0.0, float("nan")):
        with pytest.raises(ModelError, match="sample period"):
            build_digital_controllers(machine, T)


def test_delay_samples_delay_the_force_exactly():
    tf = discretize_controller(pd_controller(1e6, 1e3, "displacement", 1e-4), 1e-4, "tustin")
    plain, delayed = DigitalController(tf), DigitalController(tf, delay_samples=3)
    x = np.random.default_rng(2).standard_normal(200).tolist()
    f0 = [plain.step(v) for v in x]
    f3 = [delayed.step(v) for v in x]
    assert f3[:3] == [0.0, 0.0, 0.0] and f3[3:] == f0[:-3]
    np.testing.assert_allclose(f0, -scipy.signal.lfilter(tf.b, tf.a, x), rtol=1e-12)
    assert delayed.state["delay"] == tuple(x[-3:])
    twin = DigitalController(tf, delay_samples=3)
    twin.set_state(delayed.state)                       # checkpoint and resume
    assert [twin.step(v) for v in x[:20]] == [delayed.step(v) for v in x[:20]]
    with pytest.raises(ModelError, match="delay state must be 3"):
        twin.set_state({"filter": (0.0, 0.0), "delay": (1.0,)})
    # a state without a last force (a filter state set by hand) starts from 0 N, as after a
    # reset: a rejected first sample holds 0 N
    twin.set_state({"filter": delayed.state["filter"], "delay": (1.0, 2.0, 3.0)})
    assert twin.last_force_n == 0.0 and twin.step(float("nan")) == 0.0
    delayed.reset()
    assert delayed.state["delay"] == (0.0, 0.0, 0.0) and delayed.last_force_n == 0.0


def test_steady_state_start_with_delay_and_limits_has_no_transient():
    tf = discretize_controller(pd_controller(1e6, 1e3, "displacement", 1e-4), 1e-4, "tustin")
    block = DigitalController(tf, delay_samples=2, force_limit_n=1e6, rate_limit_n_per_s=1e3)
    block.init_steady_state(0.02)
    forces = [block.step(0.02) for _ in range(50)]
    np.testing.assert_allclose(forces, -1e6 * 0.02, rtol=1e-12)
    held = DigitalController(discretize_controller(i_controller(1.4e5, "acceleration"), 2e-4))
    held.init_steady_state(0.0, force_n=-300.0)
    assert held.last_force_n == -300.0
    assert held.step(float("nan")) == -300.0           # a rejected sample holds that force
    assert [held.step(0.0) for _ in range(10)] == [-300.0] * 10


def test_a_steady_state_at_the_force_limit_to_rounding_is_accepted():
    """PD on displacement, G_c(0) = kp = 1e6 N/m: the steady force of 7 mm is 7000 N, exactly
    the limit (the filter's state gives it 1e-15 relative above: rounding, not an excess)."""
    tf = discretize_controller(pd_controller(1e6, 1e3, "displacement", 1e-4), 1e-4, "tustin")
    block = DigitalController(tf, force_limit_n=7000.0)
    block.init_steady_state(0.007)
    np.testing.assert_allclose([block.step(0.007) for _ in range(5)], -7000.0, rtol=1e-12)
    with pytest.raises(ModelError, match="steady-state force -7007 N exceeds force_limit_n"):
        block.init_steady_state(0.007007)


def test_bumpless_gain_change_of_a_holding_integrator():
    block = DigitalController(discretize_controller(i_controller(1.4e5, "acceleration"), 2e-4))
    for v in np.sin(np.arange(100) * 0.1).tolist():
        block.step(v)
    held = block.filter.output(0.0)
    block.set_gain(0.5)
    assert block.step(0.0) == -held and block.gain == 0.5


def test_non_finite_measurement_is_refused_and_state_kept():
    block = DigitalController(discretize_controller(i_controller(1.4e5, "acceleration"), 2e-4))
    held = block.step(1.0)
    state = block.state
    assert block.step(float("nan")) == held and block.faults["implausible"] == 1
    assert block.state == state


def _integrator():
    return DigitalController(discretize_controller(i_controller(1.4e5, "acceleration"), 2e-4),
                             force_limit_n=500.0)


@pytest.mark.parametrize("delay", [-1, 1.5, True])
def test_delay_samples_must_be_a_whole_number_of_samples(delay):
    tf = discretize_controller(i_controller(1.4e5, "acceleration"), 2e-4)
    with pytest.raises(ModelError, match="delay_samples must be an integer >= 0"):
        DigitalController(tf, delay_samples=delay)


def test_a_held_force_exactly_at_the_limit_is_a_steady_state():
    """G_c = ki/s holds any force with zero input, up to force_limit_n itself (500 N); beyond
    it the start is refused and the block's state is left as it was."""
    block = _integrator()
    block.init_steady_state(0.0, force_n=500.0)
    assert [block.step(0.0) for _ in range(3)] == [500.0] * 3
    block.init_steady_state(0.0, force_n=-500.0)
    assert block.step(0.0) == -500.0
    for v in np.sin(np.arange(30) * 0.2).tolist():
        block.step(v)
    before = block.state
    with pytest.raises(ModelError, match="exceeds force_limit_n 500 N"):
        block.init_steady_state(0.0, force_n=501.0)
    assert block.state == before


def test_a_gain_is_restored_with_the_state():
    block = _integrator()
    block.set_gain(2.5)
    x = np.sin(np.arange(40) * 0.3).tolist()
    for v in x:
        block.step(v)
    twin = _integrator()
    twin.set_state(block.state)
    assert twin.gain == 2.5
    assert [twin.step(v) for v in x] == [block.step(v) for v in x]


def test_a_measurement_at_the_plausible_limit_is_accepted():
    block = DigitalController(discretize_controller(i_controller(1.4e5, "acceleration"), 2e-4),
                              measurement_limit=50.0)
    assert block.safe_output == "hold"
    assert block.step(-50.0) != 0.0 and block.step(50.0) != 0.0
    assert block.faults["implausible"] == 0
    block.step(-50.000001)
    assert block.faults["implausible"] == 1
    assert "measurements beyond +-50 m/s^2 rejected (hold)" in block.describe()
    unlimited = DigitalController(block.tf)
    assert "rejected" not in unlimited.describe()
