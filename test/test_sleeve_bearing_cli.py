"""``rotor-avc poles | frf | study`` on the Werner 2019 configs."""
import csv
import json

import numpy as np
import pytest

from rotor_avc.cli import main

from browser_check import check_report

POINTS = ("bearing", "foundation_L", "foundation_R", "actuator_L", "actuator_R")
EXCITATIONS = ("mass_eccentricity", "magnetic_eccentricity", "bent_rotor")


def test_poles_json(capsys):
    assert main(["poles", "sleeve_bearing_motor_velocity", "--speed-hz", "19", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["stable"] and len(out["poles"]) >= 13
    assert all(r["re"] < 0 for r in out["poles"])


def test_poles_default_to_the_rated_speed(capsys):
    assert main(["poles", "sleeve_bearing_motor", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["speed_hz"] == 60.0


def test_poles_at_standstill_is_a_clear_error(capsys):
    assert main(["poles", "sleeve_bearing_motor", "--speed-hz", "0"]) == 2
    err = capsys.readouterr().err
    assert "tabulated for 100 .. 6000 rpm" in err and "Traceback" not in err


def test_frf_columns(tmp_path, capsys):
    assert main(["frf", "sleeve_bearing_motor", "--speed-hz", "5:75:50", "--out", str(tmp_path),
                 "--no-plots"]) == 0
    with open(tmp_path / "frf.csv") as fh:
        header = next(csv.reader(fh))
    names = {h.rsplit("_", 1)[0] for h in header[1:] if h.endswith("_mag")}
    want = {f"{p}_{'f' if p.startswith('actuator') else 'v'}{axis}_{e}"
            for p in POINTS for axis in ("z", "y") for e in EXCITATIONS
            if not (p.startswith("actuator") and axis == "y")}
    assert names == want


def test_study_writes_tables_and_plots(tmp_path, capsys):
    assert main(["study", "sleeve_bearing_motor", "--feedback", "velocity", "--gains",
                 "1e5:1e6:4", "--out", str(tmp_path)]) == 0
    stem = tmp_path / "sleeve_bearing_motor_velocity"
    for suffix in ("_curves.csv", "_summary.csv", "_curves.png", "_resonances.png"):
        assert (stem.parent / (stem.name + suffix)).is_file()
    with open(stem.parent / (stem.name + "_summary.csv")) as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r["kp_P"]) for r in rows] == [0.0, 1e5, 4e5, 7e5, 1e6]
    red = [float(r["bearing_vz@1142rpm_reduction_window_pct"]) for r in rows]
    assert red[0] == 0.0 and np.all(np.diff(red) > 0)
    assert "bearing_vz@1142rpm" in capsys.readouterr().out
    assert check_report(stem.parent / (stem.name + ".html")) >= 4


@pytest.mark.parametrize("argv,message", [
    (["--feedback", "velocity", "--gains", "1:2"], "START:STOP:N"),
    (["--feedback", "velocity", "--structure", "PD"], "needs fixed values for kd"),
    (["--feedback", "velocity", "--fixed", "kd"], "NAME=VALUE"),
])
def test_study_refusals(tmp_path, capsys, argv, message):
    assert main(["study", "sleeve_bearing_motor", "--out", str(tmp_path)] + argv) == 2
    assert message in capsys.readouterr().err
