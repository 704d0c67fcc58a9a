"""Scenario files: the shipped ones load and run; bad scenarios fail with a clear message that
names the field; `rotor-avc simulate` writes the time series."""
import math

import numpy as np
import pytest
import yaml

from rotor_avc.cli import main
from rotor_avc.errors import ConfigError
from rotor_avc.scenario import load_scenario, relevant_mode_hz
from rotor_avc.sim.timeseries import TimeSeries

SHIPPED = ["scenario_case3_steady", "scenario_case2_runup", "scenario_case3_stepped"]


def scenario_file(tmp_path, simulation, include="foot_mount_case3.yaml", **top):
    from rotor_avc.config import find_config
    data = {"include": str(find_config(include).resolve()), "simulation": simulation, **top}
    path = tmp_path / "scn.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


BASE = {"sample_rate_hz": 5000.0, "duration_s": 0.05, "speed": {"type": "constant",
                                                                "speed_hz": 20.0},
        "unbalance": {"static": {"magnitude": 1.0e-2, "phase_deg": 30.0}}}


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_scenarios_load(name):
    scn = load_scenario(name)
    assert scn.sample_period_s == pytest.approx(1 / 5000)
    assert scn.duration_s > 0 and scn.n_steps == round(scn.duration_s * 5000)
    assert set(scn.amplitudes) <= {e.name for e in scn.machine.plant.excitations}


def test_scenario_values(tmp_path):
    scn = load_scenario(scenario_file(tmp_path, dict(BASE, damping_at="whirl",
                                                     whirl_rad_s=650.0)))
    assert scn.amplitudes["static"] == pytest.approx(1e-2 * complex(math.cos(math.pi / 6),
                                                                    math.sin(math.pi / 6)))
    assert scn.damping.kind == "whirl" and scn.damping.whirl_rad_s == 650.0
    assert scn.initial_state == "rest" and scn.n_steps == 250
    ts = scn.run(progress=False)
    assert len(ts) == 250 and ts.metadata["damping"].startswith("w_F frozen")
    # case 3 relevant modes: the sixth machine mode (104.66 Hz undamped, digest 8.2)
    assert relevant_mode_hz(scn.machine) == pytest.approx(104.66, abs=0.01)


@pytest.mark.parametrize("change, field, words", [
    ({"duration_s": -1.0}, "simulation.duration_s", "must be > 0"),
    ({"duration_s": None}, "simulation.duration_s", "has no length"),
    ({"sample_rate_hz": 300.0, "speed": {"type": "constant", "speed_hz": 200.0}},
     "simulation.sample_rate_hz", "twice the highest rotational frequency"),
    ({"sample_rate_hz": 150.0, "speed": {"type": "constant", "speed_hz": 20.0}},
     "simulation.sample_rate_hz", "highest relevant mode"),
    ({"speed": {"type": "ramp", "start_hz": 0.0, "stop_hz": 400.0, "duration_s": 1.0}},
     "simulation.speed", "beyond the model's range"),
    ({"speed": {"type": "constant", "speed_hz": -3.0}}, "simulation.speed.speed_hz", ">= 0"),
    ({"speed": {"type": "ramp", "start_hz": 0.0, "stop_hz": 10.0, "duration_s": 1.0},
      "initial_state": "steady_state"}, "simulation.initial_state", "turning at t = 0"),
    ({"unbalance": {"dynamic": {"magnitude": 1.0}}}, "simulation.unbalance.dynamic", "unknown"),
    ({"unbalance": {"static": {"magnitude": -1.0}}}, "simulation.unbalance.static.magnitude",
     ">= 0"),
    ({"damping_at": "whirl"}, "simulation.whirl_rad_s", "missing"),
    ({"whirl_rad_s": 100.0}, "simulation.whirl_rad_s", "only used with"),
    ({"damping_at": "omega"}, "simulation.damping_at", "unknown value"),
    ({"initial_state": "hot"}, "simulation.initial_state", "unknown value"),
    ({"dt": 1e-4}, "simulation.dt", "unknown key"),
])
def test_bad_scenarios_name_the_field(tmp_path, change, field, words):
    sim = dict(BASE)
    for key, value in change.items():
        if value is None:
            sim.pop(key, None)
        else:
            sim[key] = value
    with pytest.raises(ConfigError) as exc:
        load_scenario(scenario_file(tmp_path, sim))
    assert exc.value.field == field
    assert words in str(exc.value) and exc.value.fix


def test_rate_must_match_the_controllers(tmp_path):
    path = scenario_file(tmp_path, BASE, control={"sample_rate_hz": 4000.0})
    with pytest.raises(ConfigError, match="lockstep at one rate"):
        load_scenario(path)
    scn = load_scenario(scenario_file(tmp_path, {k: v for k, v in BASE.items()
                                                 if k != "sample_rate_hz"},
                                      control={"sample_rate_hz": 4000.0}))
    assert scn.sample_period_s == pytest.approx(1 / 4000)


def test_cli_simulate(tmp_path, capsys):
    path = scenario_file(tmp_path, dict(BASE, initial_state="steady_state"))
    out = tmp_path / "out" / "run.npz"
    assert main(["simulate", str(path), "--out", str(out)]) == 0
    assert "x real time" in capsys.readouterr().out
    ts = TimeSeries.load(out)
    assert len(ts) == 250 and "actuator_DL_fz" in ts.channels
    assert ts.metadata["initial_state"] == "steady_state"
    np.testing.assert_allclose(ts.speed_rad_s, 2 * np.pi * 20.0)
    bad = scenario_file(tmp_path, dict(BASE, duration_s=-2.0))
    assert main(["simulate", str(bad), "--out", str(out)]) == 2
    assert "simulation.duration_s" in capsys.readouterr().err


def test_a_scenarios_runs_share_one_speed_grid(tmp_path):
    """The second run of a run-up scenario reuses the first one's speed grid and matrices (built
    once) and equals the first bit for bit; a stepper of another setup cannot take that grid."""
    from rotor_avc.errors import ModelError
    from rotor_avc.sim.speed_profile import constant_speed
    from rotor_avc.sim.stepper import PlantStepper
    sc = load_scenario(str(scenario_file(tmp_path, dict(
        BASE, speed={"type": "ramp", "start_hz": 10.0, "stop_hz": 30.0, "duration_s": 0.05}))))
    first = sc.run(progress=False)
    table = sc.stepper().table
    assert sc.stepper().table is table and table.nodes.size > 2
    again = sc.run(progress=False)
    for name, values in first.channels.items():
        np.testing.assert_array_equal(again.channels[name], values)
    with pytest.raises(ModelError, match="same plant, sample period"):
        PlantStepper(sc.machine.plant, sc.sample_period_s, constant_speed(20.0), table=table)
