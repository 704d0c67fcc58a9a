"""Design checks before a run: unstable, improper and unresolved designs refused with the poles
that cause them (`simulate`, `controller`), allowed with a warning by `control.allow_unstable`;
an unstable run that diverges is said; no NaN in the stable gain range.

The sampled loop's verdict is checked against the continuous closed loop (Werner 2021 eq. 43, a
separate eigenproblem): at a high sample rate the unstable poles s = ln(z)/T of the one are
those of the other."""
import math
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from rotor_avc.analysis import design_check
from rotor_avc.analysis.design_check import (DesignCheck, DesignError, check_design, check_scenario,
                                             natural_frequencies_hz)
from rotor_avc.analysis.poles import closed_loop_poles, machine_poles
from rotor_avc.cli import main
from rotor_avc.closed_loop.loop import ClosedLoop
from rotor_avc.config import find_config
from rotor_avc.control.spec import ContinuousController
from rotor_avc.machine import load_machine
from rotor_avc.scenario import load_scenario

CASE3 = ("DL", "DR", "NL")


def write(tmp_path, base: str, extra: dict, name="c.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump({"include": str(find_config(base).resolve()), **extra}))
    return path


def case3(tmp_path, controller: dict, **extra):
    return write(tmp_path, "scenario_case3_steady.yaml",
                 {"controllers": {f: controller for f in CASE3}, **extra})


HOSTILE = {
    "negative gain": ("scenario_case3_steady.yaml",
                      {"controllers": {f: {"ki": -1.4e5} for f in CASE3}}, "UNSTABLE"),
    "gain far beyond the range": ("scenario_case3_steady.yaml",
                                  {"controllers": {f: {"ki": 1.4e9} for f in CASE3}}, "UNSTABLE"),
}


def pole_scenario(tmp_path):
    """Case 2 (loops open) with one tf controller: G_c = 1.4e5/(s - 100) on DL's acceleration."""
    machine = write(tmp_path, "foot_mount_case2.yaml", {"controllers": {"DL": {
        "type": "tf", "feedback": "acceleration", "num": [1.4e5], "den": [1.0, -100.0]}}},
        "m.yaml")
    sim = yaml.safe_load(find_config("scenario_case3_steady.yaml").read_text())["simulation"]
    return write(tmp_path, "scenario_case3_steady.yaml", {"include": str(machine),
                                                          "simulation": sim}, "pole.yaml")


def ideal_pid_scenario(tmp_path):
    machine = write(tmp_path, "foot_mount_case2.yaml", {"controllers": {"DL": {
        "type": "PID", "feedback": "displacement", "kp": 1e5, "ki": 1e5, "kd": 1e3}}}, "m.yaml")
    sim = yaml.safe_load(find_config("scenario_case3_steady.yaml").read_text())["simulation"]
    return write(tmp_path, "scenario_case3_steady.yaml", {"include": str(machine),
                                                          "simulation": {**sim, "initial_state": "rest"}},
                 "pid.yaml")


@pytest.mark.parametrize("case", list(HOSTILE) + ["pole at +100 rad/s in G_c", "ideal PID"])
def test_simulate_refuses_a_hostile_design_naming_the_cause(tmp_path, capsys, case):
    if case in HOSTILE:
        base, extra, expect = HOSTILE[case]
        path = write(tmp_path, base, extra)
    elif case == "ideal PID":
        path, expect = ideal_pid_scenario(tmp_path), "improper"
    else:
        path, expect = pole_scenario(tmp_path), "right half-plane (+100+0j rad/s)"
    out = tmp_path / "run.npz"
    assert main(["simulate", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert expect in err and "Traceback" not in err and not out.exists(), err
    if expect == "UNSTABLE":
        assert "damping ratio -" in err and "allow_unstable" in err


def test_unstable_poles_agree_with_the_continuous_loop(tmp_path):
    """Negative feedback gain: the sampled loop at 50 kHz and the continuous closed loop find the
    same unstable poles (frequency and growth), at the same w_F."""
    machine = load_machine(write(tmp_path, "foot_mount_case3.yaml",
                                 {"controllers": {f: {"ki": -1.4e5} for f in CASE3}}))
    speed, w_F = 2 * math.pi * 20.0, 2 * math.pi * 30.0
    chk = check_design(machine, 1 / 50_000.0, [speed], lambda _: w_F)
    s = closed_loop_poles(ClosedLoop(machine.plant, machine.controllers), speed, w_F)
    cont = sorted((p.real, abs(p.imag) / (2 * math.pi)) for p in s if p.real > 0 and p.imag >= 0)
    samp = sorted((r["growth_per_s"], r["freq_hz"]) for r in chk.unstable_poles)
    assert len(cont) == len(samp) >= 1
    np.testing.assert_allclose(samp, cont, rtol=0.02, atol=0.05)
    # damping ratio -Re s / |s| of s = growth + j 2 pi f (the module docstring)
    for r in chk.unstable_poles:
        s_abs = math.hypot(r["growth_per_s"], 2 * math.pi * r["freq_hz"])
        assert r["damping_ratio"] == pytest.approx(-r["growth_per_s"] / s_abs, rel=1e-12)
    assert not chk.ok


def test_allow_unstable_runs_with_a_warning_and_the_divergence_is_said(tmp_path, capsys):
    path = case3(tmp_path, {"ki": -1.4e5}, control={"allow_unstable": True})
    out = tmp_path / "run.npz"
    assert main(["simulate", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "warning: the sampled closed loop at 5000 Hz is UNSTABLE" in err
    assert "the run diverged" in err and "unstable closed-loop pole" in err and "Hz" in err
    assert "sensor fault" not in err and not out.exists()


def test_run_to_the_plausibility_limit_is_a_divergence(tmp_path, capsys):
    """A gain 1e4 times the nominal one grows at ~2e4 1/s: the controllers reject the signals
    beyond their measurement_limit, and simulate says the run diverged."""
    path = case3(tmp_path, {"ki": 1.4e9}, control={"allow_unstable": True})
    assert main(["simulate", str(path), "--out", str(tmp_path / "run.npz")]) == 2
    err = capsys.readouterr().err
    assert "the run diverged" in err and "measurement_limit" in err


def test_shipped_design_passes_and_a_slow_rate_names_the_mode():
    sc = load_scenario("scenario_case3_steady")
    chk = check_scenario(sc)
    assert chk.ok and not chk.unstable_poles and chk.warnings == []
    machine = sc.machine
    f = natural_frequencies_hz(machine.plant)[:machine.analysis.worst_case.n_modes]
    w_F = machine_poles(machine, 0.0).w_F
    slow = check_design(machine, 1 / 100.0, [0.0], lambda _: w_F)
    i = int(np.flatnonzero(f >= 50.0)[0])
    assert len(slow.warnings) == 1
    assert f"mode {i + 1} at {f[i]:.4g} Hz" in slow.warnings[0] and "100 Hz" in slow.warnings[0]


def test_controller_command_never_prints_nan(tmp_path, capsys):
    assert main(["controller", str(pole_scenario(tmp_path)), "--foot", "DL",
                 "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "nan" not in err.lower() and "no stable gain factor g in [0.0001, 10000]" in err
    assert main(["controller", "foot_mount_case3", "--foot", "DL", "--rate-hz", "1e12",
                 "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "not resolved in double precision" in err and "lower the sample rate" in err
    assert main(["controller", "foot_mount_case3", "--foot", "DL", "--rate-hz", "1e6",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "nominal g = 1 stable" in out and "nan" not in out.lower()


def test_refusal_is_an_error_unless_allowed():
    sc = load_scenario("scenario_case3_steady")
    chk = check_scenario(sc)
    chk.refusals.append("made up")
    with pytest.raises(DesignError, match="made up.*allow_unstable: true"):
        chk.enforce(False, "here")
    assert chk.enforce(True, "here") == ["made up (running anyway: control.allow_unstable is true)"]


def test_a_fatal_reason_is_not_offered_allow_unstable_as_a_fix():
    chk = DesignCheck(5000.0, refusals=["unstable"], fatal=["improper"])
    with pytest.raises(DesignError) as err:
        chk.enforce(False, "here")
    assert str(err.value) == "here: improper; unstable"


def test_an_improper_controller_is_fatal_before_the_loop_is_built(tmp_path):
    chk = check_scenario(load_scenario(ideal_pid_scenario(tmp_path)))
    assert len(chk.fatal) == 1 and chk.fatal[0].startswith("controllers.DL: the PID controller")
    assert chk.unstable_poles == [] and chk.refusals == []


def refusals(den) -> list[str]:
    """The controller checks' refusals of G_c = 1 / den(s) on DL."""
    ctrl = ContinuousController(np.array([1.0]), np.asarray(den, float), "displacement")
    out = DesignCheck(5000.0)
    design_check._controller_checks(SimpleNamespace(controllers={"DL": ctrl}), out)
    return out.refusals


def test_poles_on_the_imaginary_axis_are_not_in_the_right_half_plane():
    """G_c = 1 / ((s^2 + 100)(s + 5)): poles +-10j (np.roots gives them a real part of +4e-15)
    and -5, marginally stable, accepted; a pole at +1e-3 rad/s is refused; a constant
    denominator has no pole."""
    assert refusals(np.polymul([1.0, 0.0, 100.0], [1.0, 5.0])) == [] == refusals([2.0])
    [refusal] = refusals(np.polymul([1.0, 0.0, 100.0], [1.0, -1e-3]))
    assert "right half-plane (+0.001+0j rad/s)" in refusal


def test_a_right_half_plane_pole_is_judged_against_the_largest_pole():
    """np.roots errs by about eps x the largest root: with a pole at -1e4 rad/s, a root at
    +1e-6 rad/s (den s^2 + 1e4 s - 1e-2) is within 1e-9 x 1e4 of the axis -- round-off of a
    converted or fitted G_c, accepted -- and one at +1e-4 (den s^2 + 1e4 s - 1) is refused."""
    assert refusals([1.0, 1e4, -1e-2]) == []
    [refusal] = refusals([1.0, 1e4, -1.0])
    assert "right half-plane (+0.0001+0j rad/s)" in refusal
