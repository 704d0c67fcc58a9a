"""Verdicts that act like verdicts: `rotor-avc api684`'s overall verdict line and exit status on a
passing and a failing config, its --out files and stated damping rule (checked against the FRF
recomputed at that damping frequency), `rotor-avc poles`' damping rule (checked against the
poles), and the robustness study's resonance peaks told apart from a maximum at the grid end
(synthetic curves and a real study)."""
import json

import numpy as np
import pytest

from rotor_avc.analysis.api684 import check_response, overall_verdict, verdict_line
from rotor_avc.analysis.poles import closed_loop_poles
from rotor_avc.analysis.robustness import resonance_peak
from rotor_avc.cli import main
from rotor_avc.closed_loop.frf import unbalance_frf
from rotor_avc.config import find_config
from rotor_avc.machine import load_machine

PASSING = ["api684", "sleeve_bearing_motor", "--operating-hz", "50:60", "--speed-hz", "5:75:141"]


def sdof(speed_hz, fn_hz, zeta):
    r = speed_hz / fn_hz
    return 1.0 / np.sqrt((1 - r**2) ** 2 + (2 * zeta * r) ** 2)


def softer_housing(tmp_path):
    """Werner 2019's motor with softer horizontal housings: a mode moves into 50 .. 60 Hz."""
    path = tmp_path / "soft.yaml"
    path.write_text(f"include: {find_config('sleeve_bearing_motor')}\n"
                    "motor:\n  housing_stiffness_n_per_m: {z: 5.7e+8, y: 3.0e+8}\n")
    return str(path)


def test_passing_config_prints_pass_and_writes_the_files(tmp_path, capsys):
    out = tmp_path / "api"
    assert main(PASSING + ["--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert main(PASSING + ["--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    rows = [r for rs in document["responses"].values() for r in rs]
    assert rows and all(r["verdict"] in ("pass", "critically damped") for r in rows)
    assert text.rstrip().splitlines()[-1] == f"API 684: PASS ({len(rows)} of {len(rows)} requirements met)"
    assert json.loads((out / "api684.json").read_text()) == document
    assert (out / "api684.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert document["verdict"] == {"verdict": "PASS", "requirements": len(rows), "met": len(rows),
                                   "failed": [], "undetermined": []}
    assert "damping: forced response" in text and "w_F = Omega at every speed" in document["damping_rule"]


def test_the_stated_damping_rule_is_what_the_response_uses():
    """The FRF recomputed with w_F = Omega explicitly is the command's; another w_F is not."""
    machine = load_machine("sleeve_bearing_motor")
    assert machine.analysis.damping_floor_hz <= 5.0                # the grid starts above it
    speeds = 2 * np.pi * np.linspace(5.0, 75.0, 141)
    default = unbalance_frf(machine.loop, speeds).responses["bearing_vz_mass_eccentricity"]
    at_speed = unbalance_frf(machine.loop, speeds, w_F=speeds).responses["bearing_vz_mass_eccentricity"]
    at_double = unbalance_frf(machine.loop, speeds, w_F=2 * speeds).responses["bearing_vz_mass_eccentricity"]
    assert np.allclose(default, at_speed, rtol=1e-9)
    assert not np.allclose(np.abs(default), np.abs(at_double), rtol=1e-3)


def test_failing_config_exits_1_and_names_the_row(tmp_path, capsys):
    config = softer_housing(tmp_path)
    args = ["api684", config, "--operating-hz", "50:60", "--speed-hz", "5:75:141"]
    assert main(args) == 1
    last = capsys.readouterr().out.rstrip().splitlines()[-1]
    assert main(args + ["--json"]) == 1
    document = json.loads(capsys.readouterr().out)
    failing = [(n, r) for n, rs in document["responses"].items() for r in rs if r["verdict"] == "fail"]
    assert failing and all(r["position"] == "within" for _, r in failing)
    assert all(50.0 <= r["speed_hz"] <= 60.0 for _, r in failing)
    assert last.startswith("API 684: FAIL (")
    for name, r in failing:
        assert f"{name} at {r['speed_hz']:.4g} Hz" in last and "inside the operating range" in last
    assert document["verdict"]["verdict"] == "FAIL"
    assert document["verdict"]["met"] == document["verdict"]["requirements"] - len(failing)


def test_overall_verdict_of_synthetic_responses():
    """Two modes (pass and fail by the margins worked out in test_api684) and one whose lower
    half-power point lies before the record (undetermined: listed, not counted)."""
    speed = np.linspace(5.0, 150.0, 20001)
    amp = sdof(speed, 40.0, 0.02) + sdof(speed, 120.0, 0.02)
    ok = check_response(speed, amp, (50.0, 90.0))               # 20 % and 33 %: both pass
    bad = check_response(speed, amp, (45.0, 100.0))             # 11 % < 16 %, 20 % < 26 %
    short = np.linspace(38.0, 60.0, 500)
    open_end = check_response(short, sdof(short, 40.0, 0.05), (50.0, 55.0))
    v = overall_verdict({"a": ok, "b": open_end})
    assert (v["verdict"], v["requirements"], v["met"], len(v["undetermined"])) == ("PASS", 2, 2, 1)
    assert verdict_line(v).startswith("API 684: PASS (2 of 2 requirements met); 1 row(s) undetermined")
    v = overall_verdict({"a": ok, "b": bad})
    assert (v["verdict"], v["requirements"], v["met"]) == ("FAIL", 4, 2)
    assert "b at 39.98 Hz (AF" in verdict_line(v) and "< required 16 %" in verdict_line(v)


def test_poles_state_their_damping_rule(capsys):
    """Werner 2021's worst case: every mode at the 6th mode's whirl frequency -- the printed
    w_F is the 6th oscillating pole pair's frequency of the poles at that w_F (5 % tolerance of
    the iteration)."""
    assert main(["poles", "foot_mount_case3", "--speed-hz", "50", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert "mode 6" in data["damping_rule"] and "worst_case" in data["damping_rule"]
    machine = load_machine("foot_mount_case3")
    poles = closed_loop_poles(machine.loop, 2 * np.pi * 50, data["damping_frequency_rad_s"])
    sixth = np.sort(poles.imag[poles.imag > 1e-6])[5]
    assert sixth == pytest.approx(data["damping_frequency_rad_s"], rel=0.05)
    assert main(["poles", "sleeve_bearing_motor"]) == 0
    assert "damping: loss-factor damping c tan(delta) / w_F of each mode at its own whirl" in (
        capsys.readouterr().out)


@pytest.mark.parametrize("lo, hi, peak_hz, end", [
    (5.0, 35.0, None, "high"),        # rising towards a resonance at 40 Hz beyond the grid
    (45.0, 90.0, None, "low"),        # falling from one before it
    (5.0, 90.0, 40.0, None),          # the resonance inside
])
def test_resonance_peak_or_grid_end_of_synthetic_curves(lo, hi, peak_hz, end):
    speed = np.linspace(lo, hi, 3001)
    peak, at, grid_end = resonance_peak(speed, sdof(speed, 40.0, 0.02))
    assert grid_end == end
    if peak_hz is None:
        assert peak is None and at is None
    else:
        assert at == pytest.approx(peak_hz * np.sqrt(1 - 2 * 0.02**2), abs=0.03)
        assert peak == pytest.approx(1 / (2 * 0.02 * np.sqrt(1 - 0.02**2)), rel=1e-4)


def test_interior_peak_beside_a_higher_grid_end():
    """A resonance at 20 Hz on a response rising to the grid end: the peak is the resonance's,
    and the maximum is reported at the high end."""
    speed = np.linspace(5.0, 60.0, 2001)
    amp = sdof(speed, 20.0, 0.05) + (speed / 10.0) ** 2
    peak, at, end = resonance_peak(speed, amp)
    assert end == "high" and 18.0 < at < 21.0
    i = int(np.argmin(np.abs(speed - at)))
    assert peak == amp[i] and amp[i - 1] < peak > amp[i + 1]


def test_a_real_study_reports_the_grid_end_apart(tmp_path, capsys):
    """Werner 2021 case 3 up to 80 Hz: bearing_D_vz_static rises to the grid end (its resonance
    is at ~104 Hz), bearing_D_vz_moment peaks at ~21 Hz inside it (the base machine's FRF)."""
    speed_hz = np.linspace(1.0, 80.0, 160)
    frf = unbalance_frf(load_machine("foot_mount_case3").loop, 2 * np.pi * speed_hz)
    assert np.argmax(np.abs(frf.responses["bearing_D_vz_static"])) == speed_hz.size - 1
    inner = np.abs(frf.responses["bearing_D_vz_moment"])
    assert 0 < np.argmax(inner) < speed_hz.size - 1
    out = tmp_path / "robust"
    assert main(["study", "robustness", "foot_mount_case3", "--sample",
                 "foundation.stiffness_n_per_m.z*=normal(1, 0.02)", "--n", "3", "--speed-hz",
                 "1:80:160", "--workers", "1", "--no-plots", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert ("bearing_D_vz_static: maximum at the grid end (rising): extend the speed range "
            "(3 of 3 points; low end 0, high end 3)") in text
    summary = json.loads((out / "summary.json").read_text())
    assert summary["grid_end"]["bearing_D_vz_static"]["high"] == 3
    assert "bearing_D_vz_moment" not in summary["grid_end"]
    table = np.load(out / "points.npz")
    assert list(table["grid_end_max_bearing_D_vz_static"]) == ["high"] * 3
    assert list(table["grid_end_max_bearing_D_vz_moment"]) == [""] * 3
    assert np.all(table["peak_speed_hz_bearing_D_vz_static"] < 80.0)
    assert np.all(np.abs(table["peak_speed_hz_bearing_D_vz_moment"] - speed_hz[np.argmax(inner)]) < 1.0)
    rows = (out / "summary.csv").read_text().splitlines()
    assert any(r.startswith("grid_end_max_bearing_D_vz_static,,3,") and "extend the speed range" in r
               for r in rows)
