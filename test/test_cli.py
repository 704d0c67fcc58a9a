"""The command-line contract that users and checks depend on."""
import argparse
import csv
import json
import re
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


def test_speed_in_rpm_is_the_same_speed_in_hz(capsys):
    """`--speed-rpm` is `--speed-hz` times 60 wherever a speed is taken (a single speed, a grid)."""
    assert main(["poles", "foot_mount_case3", "--speed-rpm", "3000", "--json"]) == 0
    in_rpm = json.loads(capsys.readouterr().out)
    assert main(["poles", "foot_mount_case3", "--speed-hz", "50", "--json"]) == 0
    assert in_rpm == json.loads(capsys.readouterr().out)
    assert in_rpm["speed_hz"] == 50.0
    args = build_parser("campbell").parse_args(["campbell", "x", "--speed-rpm", "0:6000:3"])
    np.testing.assert_allclose(args.speed_hz, [0.0, 50.0, 100.0], rtol=0, atol=1e-12)
    args = build_parser("harmonic").parse_args(["harmonic", "commission", "x",
                                                "--speed-rpm", "1200,3000"])
    assert args.speed_hz == [20.0, 50.0]
    for command in COMMANDS:                   # every command with --speed-hz also takes rpm
        for options in _option_sets(build_parser(command)):
            assert ("--speed-hz" in options) == ("--speed-rpm" in options), command


def _option_sets(parser):
    """The option strings of each (sub-)parser under ``parser``."""
    options, nested = set(), []
    for action in parser._actions:
        options.update(action.option_strings)
        if isinstance(action, argparse._SubParsersAction):
            nested += [s for p in action.choices.values() for s in _option_sets(p)]
    return [options, *nested]


def test_speed_options_refuse_in_their_unit():
    """A bad rpm value is refused naming rpm, not Hz; both units at once are refused."""
    r = run_cli("campbell", "foot_mount_case3", "--speed-rpm", "6000:0:5")
    assert r.returncode == 2 and "rpm" in r.stderr and "Hz" not in r.stderr.split("error:")[1]
    r = run_cli("poles", "foot_mount_case3", "--speed-rpm", "60", "--speed-hz", "1")
    assert r.returncode == 2 and "not allowed with argument" in r.stderr


def test_campbell_takes_the_configs_speed_grid_as_frf_does(capsys):
    """Without `--speed-hz`, campbell uses the config's analysis.frf_speed_hz, as frf does."""
    assert main(["campbell", "foot_mount_case3", "--json"]) == 0
    speeds = json.loads(capsys.readouterr().out)["speed_hz"]
    from rotor_avc.machine import load_machine
    grid = load_machine("foot_mount_case3").analysis.frf_speed_hz
    np.testing.assert_allclose(speeds, np.linspace(grid.start, grid.stop, grid.n), rtol=1e-12)


def test_a_machine_config_run_as_a_scenario_names_the_scenarios_using_it():
    r = run_cli("simulate", "foot_mount_case3", "--out", "x.npz")
    assert r.returncode == 2
    assert "this is a machine config, not a scenario" in r.stderr
    assert "scenario_case3_steady" in r.stderr and "scenario_case3_stepped" in r.stderr
    assert "scenario_case2_runup" not in r.stderr          # a case-2 machine
    assert r.stderr.count("\n") == 1


def test_frf_writes_an_interactive_page_of_its_curves(tmp_path, capsys):
    """`frf` writes index.html beside frf.csv: one plot per point and excitation, the magnitudes of
    the CSV, read in a browser as every report is."""
    from browser_check import check_report
    out = tmp_path / "frf"
    assert main(["frf", "foot_mount_case3", "--speed-hz", "1:120:300", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {out / 'index.html'}" in printed and f"wrote {out / 'plotly.min.js'}" in printed
    with open(out / "frf.csv") as fh:
        rows = list(csv.DictReader(fh))
    # a plot per point and excitation with a nonzero component: <point>_<component>_<excitation>
    expected = {"frf_{}_{}".format(c.rsplit("_", 3)[0], c.rsplit("_", 2)[1])
                for c in rows[0] if c.endswith("_mag") and any(float(r[c]) for r in rows)}
    ids = set(re.findall(r'class="plot" id="([^"]+)"', (out / "index.html").read_text()))
    assert ids == expected and "frf_bearing_D_static" in ids
    assert check_report(out / "index.html") == len(expected)
