"""Commissioning harmonic control (`rotor-avc harmonic commission`, rotor_avc/harmonic/commission.py)
on a machine whose true influence differs from the controller's model: the Werner 2021 open feet
with the actuators' vertical stiffness x1.5 (1.05e7 -> 1.575e7 N/m), the model the nominal
machine. The identified matrix is checked against the true plant's continuous FRF at the speed
(rotor_avc.analysis.transfer.transfer_frf, a second method) times the zero-order hold's
fundamental ``(1 - e^{-j w T}) / (j w T)``; the commissioned controller against one that
adapts on the model."""
import copy
import json

import numpy as np
import pytest

from rotor_avc.analysis.order_tracking import phasor
from rotor_avc.analysis.transfer import transfer_frf
from rotor_avc.cli import main
from rotor_avc.config import load_config
from rotor_avc.scenario import scenario_from_config

NOMINAL = "scenario_harmonic_case2_steady"
SENSORS = ["bearing_D_vz", "bearing_N_vz"]
ACTUATORS = ["DL", "DR", "NL"]
FS = 5000.0
RESONANCE_HZ = FS / 290          # the nominal machine's 17.24 Hz bearing resonance


def machine_file(folder, speed_hz, extra=""):
    """The true machine: the nominal scenario, stiffer actuators, at ``speed_hz``."""
    from rotor_avc.config import find_config
    path = folder / "machine.yaml"
    path.write_text(f"include: [{find_config(NOMINAL)}]\n"
                    "elements: {actuator: {stiffness_n_per_m: {z: 1.575e+7}}}\n"
                    f"simulation: {{speed: {{type: constant, speed_hz: {speed_hz!r}}}}}\n" + extra)
    return path


@pytest.fixture(scope="module")
def at_resonance(tmp_path_factory):
    folder = tmp_path_factory.mktemp("resonance")
    path = machine_file(folder, RESONANCE_HZ)
    rc = main(["harmonic", "commission", str(path), "--model", NOMINAL, "--out",
               str(folder / "out"), "--max-added-vibration", "1.0"])
    return path, folder / "out", rc


def true_influence(path, speed_hz):
    scen = scenario_from_config(load_config(path).data, str(path))
    w, T = 2 * np.pi * speed_hz, scen.sample_period_s
    hold = (1 - np.exp(-1j * w * T)) / (1j * w * T)
    return np.array([[transfer_frf(scen.machine.loop, w, [speed_hz], a, SENSORS,
                                   w).responses[s][0] * hold for a in ACTUATORS]
                     for s in SENSORS])


def test_identified_matrix_is_the_true_plants_not_the_models(at_resonance):
    path, out, rc = at_resonance
    assert rc == 0
    doc = json.loads((out / "commission.json").read_text())
    entry = doc["speeds"][0]
    G_id = np.array(entry["identified"][0])
    G_id = G_id[..., 0] + 1j * G_id[..., 1]
    G_model = np.array(entry["model"][0])
    G_model = G_model[..., 0] + 1j * G_model[..., 1]
    G_true = true_influence(path, RESONANCE_HZ)
    scale = np.abs(G_true).max()
    # the model is off by about 70 deg and x0.35 here; the identification within 1 % of the
    # largest element (measured: 0.1 %), the test phasors' transients settled to 0.5 %
    assert np.abs(G_model - G_true).max() > 0.5 * scale
    assert np.abs(G_id - G_true).max() < 0.01 * scale
    assert max(entry["settling"][0]) < 0.005
    assert entry["test_force_n"] == [[100.0, 100.0, 100.0]]


def test_margin_below_the_configured_minimum_is_refused(at_resonance, capsys):
    path, out, _ = at_resonance
    margin = json.loads((out / "commission.json").read_text())["speeds"][0]["phase_margin_deg"]
    assert 0 < margin < 85.5                # below the quasi-steady acos(0.15 / 2) = 85.7 deg
    rc = main(["harmonic", "commission", str(path), "--model", NOMINAL, "--out",
               str(out.parent / "refused"), "--max-added-vibration", "1.0",
               "--min-margin-deg", "80"])
    err = [line for line in capsys.readouterr().err.strip().splitlines()
           if " ETA " not in line]             # the progress of the test steps aside
    assert rc == 1 and len(err) == 1
    assert f"phase margin {margin:.1f} deg" in err[0]
    assert "min_phase_margin_deg 80 deg" in err[0]
    assert not (out.parent / "refused" / "commissioned.yaml").exists()


def test_test_level_above_the_actuator_limit_is_refused_naming_the_key(tmp_path, capsys):
    path = machine_file(tmp_path, 50.0, "harmonic: {force_limit_n: 50.0}\n")
    rc = main(["harmonic", "commission", str(path), "--out", str(tmp_path / "out"),
               "--test-force-n", "80"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "harmonic.commission.test_force_n" in err and "force_limit_n 50 N" in err


def test_added_vibration_bound_halves_then_stops_the_test(tmp_path, capsys):
    path = machine_file(tmp_path, 50.0)
    rc = main(["harmonic", "commission", str(path), "--out", str(tmp_path / "out"),
               "--max-added-vibration", "1e-9"])
    err = capsys.readouterr().err
    assert rc == 1 and "the test stopped" in err and "after 4 halvings" in err
    assert "6.25 N" in err                  # 100 N halved four times


def levels_db(ts, speed_hz, start_s=1.0):
    P = int(round(FS / speed_hz))
    y = np.stack([ts.channels[c] for c in SENSORS], axis=1)
    amps = np.array([np.abs(phasor(ts.angle_rad[i:i + P], y[i:i + P]))
                     for i in range(0, y.shape[0] - P + 1, P)])
    return 20 * np.log10(amps / amps[int(round(start_s * speed_hz)) - 1])


def test_commissioned_controller_converges_where_the_model_one_lags(tmp_path, capsys):
    path = machine_file(tmp_path, 50.0)
    out = tmp_path / "out"
    assert main(["harmonic", "commission", str(path), "--model", NOMINAL, "--out", str(out),
                 "--max-added-vibration", "1.0"]) == 0
    assert main(["config", "check", str(out / "commissioned.yaml")]) == 0
    capsys.readouterr()
    data = copy.deepcopy(load_config(out / "commissioned.yaml").data)
    data["simulation"]["duration_s"] = 5.0
    commissioned = levels_db(scenario_from_config(data, "commissioned").run(), 50.0)
    # the uncommissioned controller: the nominal model's table with a declared error of 60 deg
    # and x1.5 (beyond the loop's 29 deg exact phase limit at 50 Hz, within the quasi-steady one)
    model = copy.deepcopy(load_config(NOMINAL).data)
    model["simulation"].update(speed={"type": "constant", "speed_hz": 50.0}, duration_s=5.0)
    model["harmonic"]["influence"] = {"phase_error_deg": 60.0, "magnitude_factor": 1.5}
    block = scenario_from_config(model, "model").harmonic()
    machine = copy.deepcopy(load_config(path).data)
    machine["simulation"]["duration_s"] = 5.0
    uncommissioned = levels_db(scenario_from_config(machine, "machine").run(harmonic=block), 50.0)
    # measured: commissioned -77 / -72 dB after 4 s, the model's -39 / -19 dB
    assert commissioned[-1].max() < -60.0
    assert uncommissioned[-1].max() > commissioned[-1].max() + 20.0
    first = [int(np.flatnonzero(np.all(db[50:] < -20.0, axis=1))[0])
             for db in (commissioned, uncommissioned) if np.any(np.all(db[50:] < -20.0, axis=1))]
    assert len(first) == 1 or first[0] < first[1]
