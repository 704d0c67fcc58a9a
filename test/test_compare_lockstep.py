"""`rotor-avc compare` on bags of the in-process lockstep loop (Werner 2021 case 3, 5 kHz): the
stepped-speed 1x response and a broadband FRF agree with the sampled-loop model within the
tolerances of the comparison, the report says so, and a bag whose configuration does not describe its
data fails with exit status 1."""
import json

import numpy as np
import pytest

from rotor_avc.compare.comparison import compare_bag
from rotor_avc.cli import main
from rotor_avc.config import find_config, load_yaml
from rotor_avc.recording import write_run_bag
from rotor_avc.compare.report import ACCEPTANCE, write_report
from rotor_avc.scenario import scenario_from_config

STEPPED = {"type": "stepped", "speeds_hz": [30.0, 102.0, 104.0, 106.0, 108.0], "dwell_s": 0.5,
           "transition_s": 0.1}
UNBALANCE = {"static": {"magnitude": 1.0e-2, "phase_deg": 0.0},
             "moment": {"magnitude": 2.0e-3, "phase_deg": 90.0}}


def case3(simulation: dict, ki: float | None = None):
    data = load_yaml(find_config("foot_mount_case3"))
    data["simulation"] = {"sample_rate_hz": 5000.0, "unbalance": UNBALANCE,
                          "initial_state": "steady_state", **simulation}
    if ki is not None:
        for foot in ("DL", "DR", "NL"):
            data["controllers"][foot]["ki"] = ki
    return scenario_from_config(data, "test")


def test_stepped_case3_passes_against_the_sampled_loop(tmp_path):
    sc = case3({"speed": STEPPED})
    comp = compare_bag(write_run_bag(tmp_path / "case3_stepped.mcap", sc, sc.run(progress=False)))
    assert comp.passed
    checks = {c.name: c for c in comp.checks}
    for name, tol in [("1x magnitude error away from resonances", 0.5),
                      ("1x magnitude error at resonances", 2.0),
                      ("resonance frequency error", 1.0)]:
        assert checks[name].tolerance == tol
        assert checks[name].value is not None and checks[name].passed     # each one evaluated
    one = comp.one_x
    np.testing.assert_allclose(one.speed_rad_s / (2 * np.pi), STEPPED["speeds_hz"], rtol=1e-9)
    assert set(one.measured) >= {"bearing_D_vz", "foundation_NR_vz", "foot_DL_az",
                                 "actuator_NL_fz"}
    resolved = [r for r in one.resonances if r["model"] == "sampled" and "measured_hz" in r]
    assert len(resolved) >= 5
    assert all(102.0 < r["model_hz"] < 108.0 for r in resolved)       # the 105 Hz mode
    # the lockstep loop IS the sampled loop: far inside the tolerances
    assert checks["1x band RMS error"].value < 0.05
    # the continuous model is reported beside it, without a verdict
    assert all(c.passed is None for c in comp.reference_metrics)

    files = write_report(comp, tmp_path / "report")
    data = json.loads(files["metrics"].read_text())
    assert data["pass"] is True and data["acceptance"] == ACCEPTANCE
    for c in data["checks"]:
        assert {"name", "value", "tolerance", "unit", "passed", "detail"} <= set(c)
    assert data["sample_rate_hz"] == 5000.0 and data["damping"] == "w_F = max(Omega, floor)"
    page = files["index"].read_text()
    assert ACCEPTANCE in page and "This run: <b>PASS</b>" in page
    assert len(files["plots"]) >= 5                  # the PNGs, linked from the page
    assert all(f'href="{p.name}"' in page and p.stat().st_size > 0 for p in files["plots"])
    assert page.count('<div class="plot"') >= 2 * len(comp.one_x.measured)   # interactive 1x
    header = files["csv"].read_text().splitlines()[0].split(",")
    assert header[:4] == ["kind", "speed_hz", "freq_hz", "channel"]


def test_a_bag_whose_configuration_does_not_match_its_data_fails(tmp_path, capsys):
    """Data of case 3 recorded under a configuration claiming other gains: exit status 1."""
    run_sc = case3({"speed": {**STEPPED, "speeds_hz": [30.0, 104.0]}})
    claimed = case3({"speed": {**STEPPED, "speeds_hz": [30.0, 104.0]}}, ki=1.1e5)
    path = write_run_bag(tmp_path / "mismatch.mcap", claimed, run_sc.run(progress=False))
    assert main(["compare", str(path), "--out", str(tmp_path / "r")]) == 1
    out = capsys.readouterr().out
    assert "FAIL  1x magnitude error away from resonances" in out and "-> FAIL" in out
    data = json.loads((tmp_path / "r" / "metrics.json").read_text())
    assert data["pass"] is False


def test_broadband_frf_of_a_test_force_agrees_with_the_sampled_transfer(tmp_path):
    sc = case3({"speed": {"type": "constant", "speed_hz": 20.0}, "duration_s": 3.0,
                "test_signal": {"actuator": "DL", "kind": "white", "rms_n": 100.0,
                                "band_hz": [2.0, 400.0], "seed": 1}})
    comp = compare_bag(write_run_bag(tmp_path / "broadband.mcap", sc, sc.run(progress=False)))
    [bb] = comp.broadband
    assert bb.speed_rad_s == pytest.approx(2 * np.pi * 20.0)
    assert bb.w_F == pytest.approx(2 * np.pi * 20.0)          # frozen at Omega, as the run
    assert bb.outputs[:3] == ["foot_DL_az", "foot_DR_az", "foot_NL_az"]
    check = next(c for c in comp.checks if c.name.startswith("broadband H1"))
    assert check.passed and check.value < 0.2
    for name, c in bb.channels["sampled"].items():
        assert c["coherent_bins"] > (0.8 if name.startswith("foot") else 0.6) * c["bins"], name
        assert c["band_rms_db"] < 0.2 and c["phase_rms_deg"] < 2.0, name
    # the 1x checks of a run with a test force are reported, not rated
    one_x = [c for c in comp.checks if c.name.startswith(("1x", "resonance"))]
    assert one_x and all(c.passed is None for c in one_x) and comp.passed
    settings = bb.estimate.settings()
    assert settings["window"] == "hann" and settings["averages"] >= 8
    assert any(n.startswith("test force: recorded") for n in comp.notes)
