"""`rotor-avc compare BAG --config --map` on recordings this package did not write: rosbag2
directories of two split files written by rosbags (test/rosbag2_corpus.py) from simulated runs
of Werner 2021 case 3, with driver-style topics (Imu at 5 kHz, one sensor upside down in g,
bearing velocities at 2.5 kHz), a tacho pulse instead of the shaft angle, 2 us stamp jitter,
1 % dropped messages and sensor noise at a stated SNR.

* stepped run-up, 30 dB SNR: the 1x response agrees with the sampled-loop model within 0.5 dB
  away from resonances, and the report lists the imperfections with the levels they were
  written with;
* broadband test force, 20 dB SNR: H1 lies within its +-2 sigma random-error band
  (Bendat & Piersol, from coherence and averages) around the sampled-loop model in at least
  85 % of the test band's bins per output (95 % for purely random error; the rest are bins next
  to the 1x line and at the band edge, where bias error dominates), and frf.uff reads back
  through pyuff with the same values;
* a mapping with a wrong scale fails;
* ``shaft.pulse_angle_deg``: the same recording with the pulse declared at 40 degrees of shaft
  angle gives every 1x phasor turned by exactly -40 degrees (``y = Re{Y e^{j theta}}`` with
  ``theta`` 40 degrees ahead), and fails.
"""
import csv
import json
import math
import re

import numpy as np
import pytest
import pyuff
import yaml

from rotor_avc.cli import main
from rotor_avc.compare.mapped_stream import compare_mapped
from rotor_avc.config import find_config, load_yaml
from rotor_avc.scenario import scenario_from_config

from rosbag2_corpus import Imperfections, corpus_map, write_corpus_bag

UNBALANCE = {"static": {"magnitude": 1.0e-2, "phase_deg": 0.0},
             "moment": {"magnitude": 2.0e-3, "phase_deg": 90.0}}
STEPPED = {"type": "stepped", "speeds_hz": [15.0, 30.0, 55.0, 80.0], "dwell_s": 1.0,
           "transition_s": 0.3}
BROADBAND = {"speed": {"type": "constant", "speed_hz": 20.0}, "duration_s": 3.0,
             "test_signal": {"actuator": "DL", "kind": "white", "rms_n": 100.0,
                             "band_hz": [2.0, 400.0], "seed": 1}}
STEPPED_IMP = Imperfections(snr_db=30.0, jitter_s=2e-6, drop_fraction=0.01, seed=1)
BROADBAND_IMP = Imperfections(snr_db=20.0, jitter_s=2e-6, drop_fraction=0.01, seed=2)


def _recording(root, simulation: dict, imp: Imperfections, test_force: bool, bearings: bool):
    data = load_yaml(find_config("foot_mount_case3"))
    data["simulation"] = {"sample_rate_hz": 5000.0, "unbalance": UNBALANCE,
                          "initial_state": "steady_state", **simulation}
    root.mkdir()
    config = root / "machine.yaml"
    config.write_text(yaml.safe_dump(data))
    sc = scenario_from_config(data, "corpus")
    bag = write_corpus_bag(root / "recording", sc.run(progress=False), imp,
                           test_force=test_force)
    mapping = root / "map.yaml"
    mapping.write_text(yaml.safe_dump(corpus_map(test_force=test_force, bearings=bearings)))
    return bag, config, mapping


@pytest.fixture(scope="module")
def stepped(tmp_path_factory):
    return _recording(tmp_path_factory.mktemp("corpus") / "stepped", {"speed": STEPPED},
                      STEPPED_IMP, test_force=False, bearings=True)


@pytest.fixture(scope="module")
def broadband(tmp_path_factory):
    return _recording(tmp_path_factory.mktemp("corpus") / "broadband", BROADBAND,
                      BROADBAND_IMP, test_force=True, bearings=False)


def test_the_corpus_is_a_split_rosbag2_directory_without_rotor_avc_metadata(stepped):
    bag = stepped[0]
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert len(info["relative_file_paths"]) == 2
    assert all((bag / f).stat().st_size > 0 for f in info["relative_file_paths"])
    assert b"rotor_avc" not in b"".join((bag / f).read_bytes() for f in info["relative_file_paths"])


def test_stepped_recording_recovers_the_1x_response_and_lists_its_imperfections(stepped,
                                                                                  tmp_path,
                                                                                  capsys):
    bag, config, mapping = stepped
    status = main(["compare", str(bag), "--config", str(config), "--map", str(mapping),
                   "--out", str(tmp_path / "report")])
    out = capsys.readouterr().out
    data = json.loads((tmp_path / "report" / "metrics.json").read_text())
    checks = {c["name"]: c for c in data["checks"]}
    off = checks["1x magnitude error away from resonances"]
    assert off["passed"] and off["value"] <= 0.5
    rms = checks["1x band RMS error"]
    assert rms["passed"] and rms["value"] <= 0.5
    assert status == 0 and data["verdict"] == "PASS", data["checks"]
    # every dwell found from the pulses, at its speed
    speeds = [float(s) for s in re.search(r"1x: stepped-speed dwells at ([\d., ]+) Hz", out)
              .group(1).split(", ")]
    np.testing.assert_allclose(speeds, STEPPED["speeds_hz"], rtol=1e-3)
    # the imperfections, per channel, at the levels the corpus wrote
    rates = {m.group(1): float(m.group(2)) for m in
             re.finditer(r"note: (\w+) \(/[\w/]+\): \d+ samples at ([\d.]+) Hz", out)}
    assert rates.keys() == {"foot_DL_az", "foot_DR_az", "foot_NL_az", "bearing_D_vz",
                            "bearing_N_vz", "actuator_DL_fz"}
    for name, rate in rates.items():
        assert rate == pytest.approx(2500.0 if name.startswith("bearing") else 5000.0, rel=1e-3)
    jitters = [float(j) for j in re.findall(r"jitter ([\d.]+) us", out)]
    # the std of an interval between two stamps with independent jitter is sqrt(2) sigma
    np.testing.assert_allclose(jitters, math.sqrt(2) * STEPPED_IMP.jitter_s * 1e6, rtol=0.15)
    for m in re.finditer(r"(\d+) samples at [\d.]+ Hz, jitter [\d.]+ us \(std of stamp "
                         r"intervals\), (\d+) dropped samples", out):
        kept, dropped = int(m.group(1)), int(m.group(2))
        assert dropped / (kept + dropped) == pytest.approx(STEPPED_IMP.drop_fraction, rel=0.4)
    assert "shaft (pulse, /tacho/pulse)" in out and "order tracking streamed" in out
    assert "linear interpolation" not in out        # no grid: each channel at its own stamps
    assert "1x random error from the noise (2 sigma" in out


def test_broadband_h1_lies_within_its_two_sigma_band_and_exports_to_uff(broadband, tmp_path,
                                                                        capsys):
    bag, config, mapping = broadband
    report = tmp_path / "report"
    assert main(["compare", str(bag), "--config", str(config), "--map", str(mapping),
                 "--out", str(report)]) in (0, 1)
    out = capsys.readouterr().out
    assert "broadband: H1/H2 at 20 Hz" in out
    rows = [r for r in csv.DictReader(open(report / "frf.csv")) if r["kind"] == "broadband"]
    metrics = json.loads((report / "metrics.json").read_text())
    n_d = re.search(r"(\d+) averages of", out).group(1)
    by_channel = {}
    for r in rows:
        by_channel.setdefault(r["channel"], []).append(r)
    assert set(by_channel) == {"foot_DL_az", "foot_DR_az", "foot_NL_az"}
    for name, rs in by_channel.items():
        coh = np.array([float(r["coherence"]) for r in rs])
        sigma = np.array([float(r["h1_sigma_rel"]) for r in rs])
        # Bendat & Piersol: eps = sqrt(1 - g^2) / (|g| sqrt(2 n_d))
        np.testing.assert_allclose(sigma, np.sqrt(1 - coh) / np.sqrt(coh * 2 * int(n_d)),
                                   rtol=1e-4)
        h1 = np.array([float(r["measured_mag"]) for r in rs])
        model = np.array([float(r["sampled_mag"]) for r in rs])
        inside = np.abs(h1 - model) <= 2 * sigma * h1
        assert inside.mean() >= 0.85, (name, inside.mean())
        assert np.median(coh) > 0.9
    assert any(c["name"].startswith("broadband H1") for c in metrics["checks"])
    # UFF type 58 round trip through pyuff
    sets = pyuff.UFF(str(report / "frf.uff")).read_sets()
    h1_sets = [s for s in sets if s["id1"].startswith("H1 foot_DL_az") and s["func_type"] == 4]
    [h1] = h1_sets
    rs = by_channel["foot_DL_az"]
    # an even abscissa is stored as start and step in the header's E13.5 fields
    np.testing.assert_allclose(h1["x"], [float(r["freq_hz"]) for r in rs], rtol=1e-5)
    np.testing.assert_allclose(np.abs(h1["data"]), [float(r["measured_mag"]) for r in rs],
                               rtol=1e-6)
    assert h1["ordinate_axis_units_lab"].strip() == "m/s^2"
    assert h1["orddenom_axis_units_lab"].strip() == "N"
    assert h1["ordinate_spec_data_type"] == 12 and h1["orddenom_spec_data_type"] == 13
    coherence = [s for s in sets if s["func_type"] == 6 and "foot_DL_az" in s["id1"]]
    np.testing.assert_allclose(coherence[0]["data"], [float(r["coherence"]) for r in rs],
                               rtol=1e-5)                  # frf.csv: 6 significant digits
    models = {s["id2"].strip() for s in sets if s["func_type"] == 4}
    assert {"measured", "sampled model", "continuous model"} <= models


def test_a_mapping_with_the_wrong_scale_fails(stepped, tmp_path):
    bag, config, _ = stepped
    wrong = corpus_map(test_force=False)
    del wrong["channels"]["foot_DL_az"]["scale"]         # the sensor publishes in g
    mapping = tmp_path / "wrong.yaml"
    mapping.write_text(yaml.safe_dump(wrong))
    comp = compare_mapped(bag, config, mapping)
    off = next(c for c in comp.checks if c.name == "1x magnitude error away from resonances")
    assert off.passed is False and off.value > 15.0           # 20 log10(9.81) = 19.8 dB


def _one_x(out):
    rows = {}
    for r in csv.DictReader(open(out / "frf.csv")):
        if r["kind"] == "1x":
            rows[(r["channel"], round(float(r["speed_hz"]), 3))] = float(r["measured_phase_deg"])
    return rows


def test_the_pulse_angle_turns_every_1x_phasor_by_it(stepped, tmp_path):
    bag, config, mapping = stepped
    turned = yaml.safe_load(mapping.read_text())
    turned["shaft"]["pulse_angle_deg"] = 40.0
    (tmp_path / "turned.yaml").write_text(yaml.safe_dump(turned))
    assert main(["compare", str(bag), "--config", str(config), "--map", str(mapping),
                 "--out", str(tmp_path / "zero")]) == 0
    assert main(["compare", str(bag), "--config", str(config), "--map",
                 str(tmp_path / "turned.yaml"), "--out", str(tmp_path / "turned")]) == 1
    zero, forty = _one_x(tmp_path / "zero"), _one_x(tmp_path / "turned")
    assert zero and set(zero) == set(forty)
    for key, phase in zero.items():
        shift = (forty[key] - phase + 180.0) % 360.0 - 180.0
        assert abs(shift + 40.0) < 2e-3, (key, shift)          # the CSV's resolution
