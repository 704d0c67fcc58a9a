"""``rotor-avc controller``: coefficients, Bode plot and stable gain range."""
import re

import numpy as np

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


def test_controller_command_errors(tmp_path, capsys):
    assert main(["controller", "foot_mount_case3", "--foot", "NR", "--out", str(tmp_path)]) == 2
    assert "controlled feet: DL, DR, NL" in capsys.readouterr().err
