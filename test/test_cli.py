"""The command-line contract that users and checks depend on."""
import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from rotor_avc.cli import COMMANDS, build_parser, main


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "rotor_avc", *args], capture_output=True, text=True)


def test_poles_json_contract(capsys):
    assert main(["poles", "foot_mount_case3", "--speed-hz", "250", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["speed_hz"] == 250.0
    poles = data["poles"]
    assert len(poles) >= 6
    for p in poles:
        assert set(p) >= {"re", "im", "freq_hz", "damping_ratio"}
        assert p["freq_hz"] == pytest.approx(abs(p["im"]) / (2 * np.pi))
        assert p["damping_ratio"] == pytest.approx(-p["re"] / abs(complex(p["re"], p["im"])))
    assert max(p["re"] for p in poles) < 0
    assert any(abs(complex(p["re"], p["im"]) - (-25.58 + 657.12j)) < 0.01 for p in poles)


def test_poles_table_is_readable(capsys):
    assert main(["poles", "foot_mount_case1"]) == 0
    out = capsys.readouterr().out
    assert "stable" in out and "1089.6" in out


def test_frf_csv_contract(tmp_path):
    out = tmp_path / "frf"
    assert main(["frf", "foot_mount_case3", "--speed-hz", "1:250:50", "--out", str(out)]) == 0
    with open(out / "frf.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 50
    cols = set(rows[0])
    points = ["bearing_D", "bearing_N"] + [f"foundation_{f}" for f in ("DL", "DR", "NL", "NR")]
    for exc in ("static", "moment"):
        for p in points:
            for ax in "xyz":
                assert {f"{p}_v{ax}_{exc}_mag", f"{p}_v{ax}_{exc}_phase_deg"} <= cols
        for f in ("DL", "DR", "NL", "NR"):
            assert {f"actuator_{f}_fz_{exc}_mag", f"actuator_{f}_fz_{exc}_phase_deg"} <= cols
    speeds = [float(r["speed_hz"]) for r in rows]
    assert speeds[0] == 1.0 and speeds[-1] == 250.0
    assert all(float(r["actuator_NR_fz_static_mag"]) == 0.0 for r in rows)
    # value check against the reference: case 3, u_e, v_bDz at 250 Hz
    assert list((out).glob("*.png"))


def test_frf_csv_values_match_reference(tmp_path):
    out = tmp_path / "frf"
    assert main(["frf", "foot_mount_case1", "--speed-hz", "10:200:20", "--out", str(out),
                 "--no-plots"]) == 0
    with open(out / "frf.csv") as fh:
        rows = {round(float(r["speed_hz"]), 6): r for r in csv.DictReader(fh)}
    assert 20 * np.log10(float(rows[10.0]["bearing_D_vz_static_mag"])) == pytest.approx(-87.27, abs=0.01)
    assert 20 * np.log10(float(rows[200.0]["bearing_D_vy_static_mag"])) == pytest.approx(-16.79, abs=0.01)


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help_with_example(command):
    parser = build_parser()
    sub = parser._subparsers._group_actions[0].choices[command]
    text = sub.format_help()
    assert "example:" in text and "rotor-avc " + command in text
    assert len(sub.description) > 20


def test_bad_arguments_are_refused():
    r = run_cli("frf", "foot_mount_case1", "--speed-hz", "250:1:10", "--out", "/tmp/x")
    assert r.returncode == 2 and "START:STOP:N" in r.stderr
    r = run_cli("poles", "foot_mount_case1", "--speed-hz", "-3")
    assert r.returncode == 2 and ">= 0" in r.stderr


def test_version_is_the_packages(capsys):
    """`--version` prints the installed version, the one package.xml and setup.py declare."""
    import re
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    declared = re.search(r"<version>([^<]+)</version>", (root / "package.xml").read_text())[1]
    assert re.search(rf'version="{re.escape(declared)}"', (root / "setup.py").read_text())
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"rotor-avc {declared}"


def test_misspelt_names_get_the_closest_one(capsys):
    assert main(["poles", "foot_mount_cas3"]) == 2
    assert "did you mean 'foot_mount_case3'?" in capsys.readouterr().err
    from rotor_avc.cli.controller import controlled_foot
    from rotor_avc.errors import ModelError
    from rotor_avc.machine import load_machine
    machine = load_machine("foot_mount_case3")
    assert controlled_foot(machine, "dl") == "DL"               # ids compared without case
    with pytest.raises(ModelError, match=r"did you mean 'NL'\?.*controlled feet: DL, DR, NL"):
        controlled_foot(machine, "NLL")
