"""The broadband test force of a simulation (simulation.test_signal, rotor_avc.sim.broadband): a
sequence fixed by the sample index, its RMS and band, added by the plant stepper to the held
force (so the in-process loop and the ROS plant node apply the same), recorded in the time
series and in the bag, and refused with a clear error when misconfigured."""
import numpy as np
import pytest
import scipy.signal

from rotor_avc.bag import BagReader
from rotor_avc.config import find_config, load_yaml
from rotor_avc.errors import ConfigError, ModelError
from rotor_avc.recording import write_run_bag
from rotor_avc.sim.broadband import BroadbandForce
from rotor_avc.sim.loop import control_plan, controller_forces, start
from rotor_avc.scenario import scenario_from_config
from rotor_avc.sim.stepper import PlantStepper

FS = 5000.0


def scenario(machine="foot_mount_case3", test=None, duration=0.4, initial="rest"):
    data = load_yaml(find_config(machine))
    data["simulation"] = {"sample_rate_hz": FS, "duration_s": duration,
                          "speed": {"type": "constant", "speed_hz": 25.0},
                          "unbalance": {"static": {"magnitude": 1.0e-2}},
                          "initial_state": initial}
    if test is not None:
        data["simulation"]["test_signal"] = test
    return scenario_from_config(data, "test")


WHITE = {"actuator": "DL", "kind": "white", "rms_n": 120.0, "band_hz": [20.0, 300.0], "seed": 4}


def test_white_force_is_fixed_by_the_sample_index_and_band_limited():
    force = BroadbandForce("DL", "z", "white", 120.0, (20.0, 300.0), 1 / FS, seed=4)
    whole = force.values(0, 200_000)
    again = BroadbandForce("DL", "z", "white", 120.0, (20.0, 300.0), 1 / FS, seed=4)
    np.testing.assert_array_equal(again.values(123_456, 5000), whole[123_456:128_456])
    np.testing.assert_array_equal(again.values(7, 3), whole[7:10])
    assert not np.array_equal(BroadbandForce("DL", "z", "white", 120.0, (20.0, 300.0), 1 / FS,
                                             seed=5).values(0, 100), whole[:100])
    assert whole.std() == pytest.approx(120.0, rel=0.03)
    f, psd = scipy.signal.welch(whole, FS, nperseg=8192)
    inside = psd[(f > 40) & (f < 250)].mean()
    assert psd[(f > 1) & (f < 5)].max() < 1e-4 * inside           # order-4 band-pass skirts
    assert psd[(f > 1200)].max() < 1e-4 * inside
    # the expected variance is the integral of the PSD: rms_n^2
    assert np.trapezoid(psd, f) == pytest.approx(120.0 ** 2, rel=0.06)


def test_chirp_sweeps_the_band_with_the_given_rms():
    force = BroadbandForce("DL", "z", "chirp", 50.0, (10.0, 200.0), 1 / FS, sweep_s=0.5)
    x = force.values(0, 5000)                       # two whole sweeps
    assert np.sqrt(np.mean(x ** 2)) == pytest.approx(50.0, rel=0.01)
    np.testing.assert_allclose(x[:2500], x[2500:], atol=1e-9)
    tau = np.arange(2500) / FS                        # linear sweep 10 -> 200 Hz in 0.5 s
    expect = np.sqrt(2) * 50.0 * np.sin(2 * np.pi * (10.0 * tau + 190.0 / (2 * 0.5) * tau ** 2))
    np.testing.assert_allclose(x[:2500], expect, atol=1e-9)


def test_the_stepper_adds_it_to_the_held_force():
    """The loop with a test force equals the loop without one whose DL force is u_k + d_k; the
    recorded actuator force stays the controller's answer, the test force its own channel."""
    sc = scenario(test=WHITE)
    ts = sc.run(progress=False)
    d = ts["test_signal_DL_fz"]
    np.testing.assert_array_equal(d, sc.test_force.values(0, len(ts)))
    assert ts.units["test_signal_DL_fz"] == "N" and ts.metadata["test_signal"]["seed"] == 4

    plain = scenario(test=None)
    stepper, ctrls = plain.stepper(), plain.controllers()
    plan = control_plan(stepper, ctrls)
    y = start(stepper, ctrls)
    u = np.zeros(stepper.n_inputs)
    i = [a.id for a in stepper.plant.actuators].index("DL")
    for k in range(len(ts)):
        np.testing.assert_allclose(y[stepper.layout.index("foot_DL_az")], ts["foot_DL_az"][k],
                                   rtol=1e-12, atol=1e-12)
        controller_forces(plan, y, u)
        assert u[i] == pytest.approx(ts["actuator_DL_fz"][k], rel=1e-12, abs=1e-9)
        applied = u.copy()
        applied[i] += d[k]
        y = stepper.step(applied)


def test_the_bag_carries_it_on_its_own_topic(tmp_path):
    sc = scenario(test=WHITE, duration=0.1)
    ts = sc.run(progress=False)
    path = write_run_bag(tmp_path / "run.mcap", sc, ts)
    with BagReader(path, require_config=True) as bag:
        series = bag.series("/avc/plant/test_signal")
        np.testing.assert_array_equal(series["test_signal_DL_fz"], ts["test_signal_DL_fz"])
        assert "test_signal_DL_fz" not in bag.series("/avc/plant/observables").labels
        assert bag.config["test_signal"]["actuator"] == "DL"
        assert bag.config["machine"]["simulation"]["test_signal"] == WHITE


@pytest.mark.parametrize("change, match", [
    ({"actuator": "NR"}, r"test_signal.actuator: unknown actuator 'NR' -- fix: use one of: "
                         r"DL, DR, NL"),
    ({"band_hz": [10.0, 2600.0]}, r"test_signal.band_hz: .*< 2500 Hz"),
    ({"band_hz": [300.0, 20.0]}, r"test_signal.band_hz"),
    ({"rms_n": 0.0}, r"test_signal.rms_n: must be > 0"),
    ({"kind": "pink"}, r"test_signal.kind: unknown value 'pink'"),
    ({"sweep_s": 1.0}, r"test_signal.sweep_s: only used with kind: chirp"),
    ({"kind": "chirp"}, r"test_signal.seed: only used with kind: white"),
    ({"amplitude": 3.0}, r"test_signal.amplitude: unknown key"),
])
def test_bad_test_signal_config_names_the_field(change, match):
    with pytest.raises(ConfigError, match=match):
        scenario(test={**WHITE, **change})


def test_bad_direct_use_is_refused():
    with pytest.raises(ModelError, match="must be > 0 N"):
        BroadbandForce("DL", "z", "white", -1.0, (1.0, 10.0), 1 / FS)
    with pytest.raises(ModelError, match="samples must be >= 0"):
        BroadbandForce("DL", "z", "chirp", 1.0, (1.0, 10.0), 1 / FS).values(-1, 3)
    sc = scenario()
    with pytest.raises(ModelError, match="share one rate"):
        PlantStepper(sc.machine.plant, 1 / FS, sc.profile,
                     test_force=BroadbandForce("DL", "z", "white", 1.0, (1.0, 10.0), 1e-3))
    with pytest.raises(ModelError, match="no actuator 'XX'"):
        PlantStepper(sc.machine.plant, 1 / FS, sc.profile,
                     test_force=BroadbandForce("XX", "z", "white", 1.0, (1.0, 10.0), 1 / FS))
