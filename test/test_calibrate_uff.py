"""`rotor-avc calibrate` on measured FRFs: a standstill impact or shaker test exported by a modal
tool as UFF type 58 (pyuff): FRFs from a force at foot DL to three responses, numbered by node
and direction (one of them on a reversed axis), coherence records beside them, a units record
(SI), complex noise at the coherence's random error. The truth: a machine with 10 % stiffer
actuators and a 25 % larger foundation loss factor than configured; its FRFs from the continuous
closed loop with the hysteretic damping model at standstill.

Stated: both recovered within 2 % and inside their 95 % intervals; the rotor's polar inertia
(gyroscopic: no effect at standstill) reported insensitive; a record of the wrong quantity and a
units record other than SI refused naming the field.
"""
import json

import numpy as np
import pyuff
import pytest
import yaml

from rotor_avc.analysis.frf_estimate import h1_random_error
from rotor_avc.analysis.transfer import transfer_frf
from rotor_avc.cli import main
from rotor_avc.compare.comparison import model_loops
from rotor_avc.config import find_config, load_yaml
from rotor_avc.machine import machine_from_config

from browser_check import check_report
from test_calibrate import assert_recovered

#: (node, direction, model signal, UFF data type) of each response; node 12 on a reversed axis
RESPONSES = [(11, 3, "foot_DL_az", 12), (12, -3, "foot_DR_az", 12), (21, 3, "bearing_D_vz", 11)]
AVERAGES, COHERENCE = 60, 0.995


def _machine():
    data = load_yaml(find_config("foot_mount_case3"))
    data.pop("simulation", None)
    return data


def _record(func_type, node, direction, freq, values, data_type):
    return pyuff.prepare_58(
        binary=0, id1=f"node {node}:{direction}", id2="modal test", id3="", id4="", id5="",
        func_type=func_type, ver_num=0, load_case_id=0, rsp_ent_name="frame", rsp_node=node,
        rsp_dir=direction, ref_ent_name="shaker", ref_node=1, ref_dir=3, z_axis_value=0.0,
        abscissa_spec_data_type=18, abscissa_len_unit_exp=0, abscissa_force_unit_exp=0,
        abscissa_temp_unit_exp=0, abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=data_type, ordinate_len_unit_exp=1, ordinate_force_unit_exp=0,
        ordinate_temp_unit_exp=0, ordinate_axis_units_lab="SI",
        orddenom_spec_data_type=13 if func_type == 4 else 0, orddenom_len_unit_exp=0,
        orddenom_force_unit_exp=1, orddenom_temp_unit_exp=0, orddenom_axis_units_lab="N",
        z_axis_spec_data_type=0, z_axis_len_unit_exp=0, z_axis_force_unit_exp=0,
        z_axis_temp_unit_exp=0, z_axis_axis_units_lab="", data=values, x=freq)


def _write_uff(path, truth, units_code=1, wrong_type=None):
    freq = np.linspace(2.0, 160.0, 317)
    machine = machine_from_config(truth, "truth")
    loop = model_loops(machine, 0.0, ("continuous",))["continuous"]
    floor = loop.plant.forced_damping_frequency(0.0)
    frf = transfer_frf(loop, 0.0, freq, "DL", [r[2] for r in RESPONSES],
                       np.maximum(2 * np.pi * freq, floor))
    rng = np.random.default_rng(5)
    eps = h1_random_error(np.full(freq.size, COHERENCE), AVERAGES)
    sets = [pyuff.prepare_164(units_code=units_code, units_description="SI", temp_mode=2,
                              length=1.0, force=1.0, temp=1.0, temp_offset=273.15)]
    for node, direction, name, data_type in RESPONSES:
        h = frf.responses[name] * np.sign(direction)
        noise = eps * np.abs(h) * (rng.standard_normal(freq.size)
                                   + 1j * rng.standard_normal(freq.size)) / np.sqrt(2)
        kind = wrong_type if wrong_type is not None and node == 21 else data_type
        sets.append(_record(4, node, direction, freq, h + noise, kind))
        sets.append(_record(6, node, direction, freq, np.full(freq.size, COHERENCE), 0))
    uff = pyuff.UFF(str(path))
    uff.write_sets(sets, mode="add")
    return path


@pytest.fixture(scope="module")
def modal_test(tmp_path_factory):
    root = tmp_path_factory.mktemp("uff")
    truth = _machine()
    truth["elements"]["actuator"]["stiffness_n_per_m"]["z"] *= 1.1
    truth["foundation"]["tan_delta"] = 0.05
    (root / "machine.yaml").write_text(yaml.safe_dump(_machine()))
    (root / "map.yaml").write_text(yaml.safe_dump({"uff": {
        "input": "DL", "speed_hz": 0.0, "averages": AVERAGES, "reference_node": 1,
        "responses": [{"node": n, "direction": d, "signal": s} for n, d, s, _ in RESPONSES]}}))
    _write_uff(root / "standstill.uff", truth)
    return root, truth


def test_measured_frfs_calibrate_the_machine(modal_test, tmp_path):
    root, truth = modal_test
    status = main(["calibrate", str(root / "standstill.uff"), "--config",
                   str(root / "machine.yaml"), "--uff-map", str(root / "map.yaml"), "--fit",
                   "elements.actuator.stiffness_n_per_m.z,foundation.tan_delta,"
                   "machine.rotor_polar_inertia_kg_m2", "--out", str(tmp_path / "cal"),
                   "--workers", "1"])
    assert status == 0
    doc = json.loads((tmp_path / "cal" / "calibration.json").read_text())
    rows = {p["path"]: p for p in doc["parameters"]}
    expected = {"elements.actuator.stiffness_n_per_m.z":
                truth["elements"]["actuator"]["stiffness_n_per_m"]["z"],
                "foundation.tan_delta": 0.05}
    assert_recovered(rows, expected, ["machine.rotor_polar_inertia_kg_m2"])
    inertia = rows["machine.rotor_polar_inertia_kg_m2"]
    assert not inertia["identifiable"] and inertia["reason"].startswith("insensitive")
    (row,) = doc["data"]
    assert row["configured"]["verdict"] is None
    assert min(row["calibrated"]["frac_h1"].values()) > 0.999
    assert row["calibrated"]["chi2"] < 2.0 < row["configured"]["chi2"]
    # H1 magnitude and phase per response, the sensitivity and correlation matrices
    assert check_report(tmp_path / "cal" / "index.html") == 2 * len(RESPONSES) + 2


@pytest.mark.parametrize("change, field", [({"units_code": 2}, "standstill.uff"),
                                           ({"wrong_type": 12}, "uff.responses[2]")])
def test_a_record_in_other_units_or_of_another_quantity_is_refused(modal_test, tmp_path, capsys,
                                                                    change, field):
    root, truth = modal_test
    path = _write_uff(tmp_path / "standstill.uff", truth, **change)
    status = main(["calibrate", str(path), "--config", str(root / "machine.yaml"),
                   "--uff-map", str(root / "map.yaml"), "--fit", "foundation.tan_delta",
                   "--out", str(tmp_path / "cal"), "--workers", "1"])
    err = capsys.readouterr().err
    assert status == 2 and field in err and err.count("\n") == 1, err
    assert not (tmp_path / "cal").exists()


def test_a_uff_file_without_its_mapping_is_refused(modal_test, tmp_path, capsys):
    root, _ = modal_test
    status = main(["calibrate", str(root / "standstill.uff"), "--config",
                   str(root / "machine.yaml"), "--fit", "foundation.tan_delta", "--out",
                   str(tmp_path / "cal")])
    assert status == 2 and "--uff-map" in capsys.readouterr().err
