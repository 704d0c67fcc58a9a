"""``rotor-avc active-bearing``: the digest-11 table, IL zero crossing, stroke-limit report, files."""
import csv
import json

import numpy as np
import pytest

from rotor_avc.cli import main


def test_report_and_files(tmp_path, capsys):
    out = tmp_path / "ab"
    assert main(["active-bearing", "active_bearing", "--speed-hz", "1:1000:200", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "positive at every shaft point" in text and "NOT positive" not in text
    assert "paper: y: 690.0 Hz" in text and "exact: y: 669.9 Hz" in text
    assert "the actuators saturate above" in text
    summary = json.loads((out / "summary.json").read_text())
    assert summary["il_zero_crossing_hz"]["paper"]["x"] == pytest.approx(690.0, abs=1.0)
    onset = summary["saturation_onset_hz"]
    assert 500.0 < onset < 1000.0
    with open(out / "il_over_speed.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 200
    f = np.array([float(r["speed_hz"]) for r in rows])
    alpha = np.array([float(r["saturation_alpha"]) for r in rows])
    assert np.all(alpha[f < onset] == 1.0) and np.all(alpha[f > onset + 5.0] < 1.0)
    for key in ("il_paper_shaft_L1_y_db", "il_exact_shaft_R5_x_db", "il_saturated_shaft_L3_x_db",
                "force_y1_n", "phase_x2_deg", "force_limit_n"):
        assert key in rows[0]
    with open(out / "cases.csv") as fh:
        cases = list(csv.DictReader(fh))
    assert len(cases) == 16 and {c["plane"] for c in cases} == {"x", "y"}
    assert all(float(c["il_paper_db"]) > 0 and float(c["il_exact_db"]) > 0 for c in cases)
    assert (out / "il_over_speed.png").stat().st_size > 0 and (out / "piezo_force.png").exists()


def test_config_problems_are_one_line_errors(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("include: " + str((__import__("pathlib").Path(__file__).parents[1]
                                       / "config" / "active_bearing.yaml").resolve())
                   + "\npiezo: {max_voltage_v: -5.0}\n")
    assert main(["active-bearing", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "piezo.max_voltage_v" in err and "Traceback" not in err
