"""``rotor-avc controller``: coefficients, Bode plot, loop margins and stable gain range."""
import json
import math
import re

import numpy as np
import pytest

from rotor_avc.analysis.poles import worst_case_poles
from rotor_avc.analysis.sampled_loop import machine_sampled_loop
from rotor_avc.cli import main
from rotor_avc.machine import load_machine


def test_controller_command(tmp_path, capsys):
    assert main(["controller", "foot_mount_case3", "--foot", "DL", "--rate-hz", "1000",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "num = [140000], den = [1, 0]" in out
    assert "b = [70, 70]" in out and "a = [1, -1]" in out        # b0 T/2 at 1 kHz
    assert (tmp_path / "controller_DL_bode.png").stat().st_size > 10_000
    upper = float(re.search(r"stable gain factor 0 < g < ([0-9.e+]+)", out).group(1))
    # the printed limit is the sampled loop's (same rate, w_F of the worst-case procedure)
    machine = load_machine("foot_mount_case3")
    w_F = worst_case_poles(machine.loop, 0.0).w_F
    ref = machine_sampled_loop(machine, 1e-3).stable_gain_range(0.0, w_F).upper
    assert np.isclose(upper, ref, rtol=1e-3)
    assert f"ki 0 .. {1.4e5 * ref:.4g}" in out
    # the all-loop factor from det(I + g L) = 0 beside the one from the poles, and a row per loop
    frf = re.search(r"1000 Hz: from the frequency response \(det\(I \+ g L\) = 0\) 0 < g < "
                    r"([0-9.e+]+); from the poles 0 < g < ([0-9.e+]+)", out)
    assert np.isclose(float(frf.group(1)), ref, rtol=1e-3) and float(frf.group(2)) == upper
    for foot in ("DL", "DR", "NL"):
        assert re.search(rf"\n  {foot} +continuous +inf +inf +- ", out)
        assert re.search(rf"\n  {foot} +1000 Hz +[0-9.]+ +[0-9.]+ +[0-9.]+ +-?[0-9.]+ ", out)
        assert (tmp_path / f"loop_{foot}_nyquist.png").is_file()


def test_controller_command_errors(tmp_path, capsys):
    assert main(["controller", "foot_mount_case3", "--foot", "NR", "--out", str(tmp_path)]) == 2
    assert "controlled feet: DL, DR, NL" in capsys.readouterr().err


def test_controller_json_margins_and_plots(tmp_path, capsys):
    """``--json``: one document with every foot's margins (null for an infinite one), the
    all-loop gain range from the poles and from the frequency response (equal to the bisection's
    tolerance), and the loop plots written."""
    assert main(["controller", "foot_mount_case3", "--foot", "DL", "--rate-hz", "1000",
                 "--speed-hz", "25", "--json", "--out", str(tmp_path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["rate_hz"] == 1000.0 and doc["speed_hz"] == 25.0
    keys = {"gain_margin", "gain_margin_db", "phase_margin_deg", "sensitivity_peak",
            "crossover_hz", "phase_crossover_hz"}
    assert sorted(doc["loops"]) == ["DL", "DR", "NL"]
    for foot, loop in doc["loops"].items():
        assert keys <= set(loop) and keys <= set(loop["continuous"])
        assert loop["gain_margin_db"] == pytest.approx(20 * math.log10(loop["gain_margin"]))
        assert loop["continuous"]["gain_margin"] is None      # skyhook damping: no crossing
        for kind in ("bode", "nyquist"):
            assert (tmp_path / f"loop_{foot}_{kind}.png").stat().st_size > 10_000
    all_loops = doc["all_loops"]
    lo, hi = all_loops["gain_range"]
    assert lo == 0.0 and all_loops["gain_margin_frf"] == [0.0, pytest.approx(hi, rel=1e-3)]
    assert 0 < all_loops["disk_margin"] < 2
    assert all_loops["continuous"]["gain_margin_frf"][1] is None
    assert (tmp_path / "controller_DL_bode.png").is_file()
