"""Campbell diagrams: agreement with `rotor-avc poles`, mode identity at crossings (MAC
tracking) against an analytic gyroscopic rotor, critical speeds and the onset of instability
against Werner 2017's threshold procedure."""
import dataclasses
import json

import numpy as np
import pytest

from rotor_avc.analysis.campbell import DAMPING_RULES, campbell_diagram, sampled_poles
from rotor_avc.analysis.stability_study import machine_threshold
from rotor_avc.cli import main
from rotor_avc.config import load_config
from rotor_avc.errors import ModelError
from rotor_avc.machine import Machine, load_machine
from rotor_avc.models.plant import LinearPlant

from browser_check import check_report

# disk on a tilting shaft (tilt stiffness k_t, inertias I_d, I_p) and an uncoupled translation
I_D, I_P, K_T = 2.0, 1.2, 8.0e5          # kg m^2, kg m^2, N m/rad -> 100.7 Hz at rest
M_Z, K_Z = 10.0, 3.4e6                   # kg, N/m -> 92.8 Hz, crossed by the backward whirl


def disk_machine(loss_factor=0.0, floor_rad_s=1.0):
    n = 3
    mass = np.diag([I_D, I_D, M_Z])
    stiff = np.diag([K_T, K_T, K_Z])
    gyro = np.zeros((n, n))
    gyro[0, 1], gyro[1, 0] = I_P, -I_P
    plant = LinearPlant("disk", ("tilt_x", "tilt_y", "z"), mass, stiff, loss_factor * stiff,
                        np.zeros((n, n)), gyro, np.zeros((n, n)), (), (), (), floor_rad_s)
    return Machine(load_config("foot_mount_case1"), plant, {})


def whirl_hz(speed_rad_s, sign):
    """Forward (+1) / backward (-1) whirl of the undamped disk: I_d w^2 -+ I_p Omega w - k_t = 0."""
    w = (sign * I_P * speed_rad_s + np.sqrt((I_P * speed_rad_s) ** 2 + 4 * I_D * K_T)) / (2 * I_D)
    return w / (2 * np.pi)


def test_crossing_modes_keep_their_identity():
    speeds = 2 * np.pi * np.linspace(0.0, 60.0, 25)
    cd = campbell_diagram(disk_machine(), speeds, rule="forced")
    f = cd.freq_hz
    # the constant translation mode is one track, though the backward whirl crosses it
    z = int(np.argmin(np.abs(f[0] - np.sqrt(K_Z / M_Z) / (2 * np.pi))))
    assert np.allclose(f[:, z], np.sqrt(K_Z / M_Z) / (2 * np.pi), rtol=1e-9)
    others = [k for k in range(3) if k != z]
    ends = sorted(others, key=lambda k: f[-1, k])
    assert np.allclose(f[1:, ends[0]], whirl_hz(speeds[1:], -1), rtol=1e-9)
    assert np.allclose(f[1:, ends[1]], whirl_hz(speeds[1:], +1), rtol=1e-9)
    # sorted by frequency, the lowest track would jump from the backward whirl to the translation
    assert f[0, z] < f[0, ends[0]] and f[-1, z] > f[-1, ends[0]]


def test_critical_speeds_are_the_analytic_ones():
    speeds = 2 * np.pi * np.linspace(0.0, 200.0, 401)
    cd = campbell_diagram(disk_machine(), speeds, rule="forced")
    one_x = sorted(r["speed_hz"] for r in cd.critical_speeds((1,)))
    expected = sorted([np.sqrt(K_T / (I_D + I_P)) / (2 * np.pi),      # backward: Omega = w
                       np.sqrt(K_T / (I_D - I_P)) / (2 * np.pi),      # forward
                       np.sqrt(K_Z / M_Z) / (2 * np.pi)])
    assert np.allclose(one_x, expected, rtol=2e-4)


def test_damping_ratio_and_log_decrement_of_loss_factor_damping():
    eta = 0.02
    w_floor = 2 * np.pi * 90.0
    cd = campbell_diagram(disk_machine(eta, w_floor), 2 * np.pi * np.array([0.0, 1.0]), rule="forced")
    # at rest, damping eta k / w_F with w_F = the floor: exact poles of m s^2 + (eta k / w_F) s + k
    for k_, m_ in ((K_T, I_D), (K_Z, M_Z)):
        s = np.roots([m_, eta * k_ / w_floor, k_])
        pole = s[s.imag > 0][0]
        j = int(np.argmin(np.abs(cd.poles[0] - pole)))
        assert abs(cd.poles[0, j] - pole) < 1e-9 * abs(pole)
        assert cd.damping_ratio[0, j] == pytest.approx(-pole.real / abs(pole), rel=1e-9)
        assert cd.log_decrement[0, j] == pytest.approx(-2 * np.pi * pole.real / pole.imag, rel=1e-9)


@pytest.mark.parametrize("config, grid, speeds_hz", [
    ("foot_mount_case3", "0:250:21", (0.0, 37.5, 150.0, 250.0)),
    ("roller_bearing_stability", "10:100:19", (10.0, 55.0, 100.0))])
def test_campbell_agrees_with_the_poles_command(capsys, config, grid, speeds_hz):
    assert main(["campbell", config, "--speed-hz", grid, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) == {"speed_hz", "modes", "critical_speeds", "reference_speed_hz",
                         "damping_rule"}
    assert all(set(m) == {"label", "freq_hz", "damping_ratio", "whirl", "shape"}
               for m in data["modes"])
    assert all(set(c) == {"mode", "order", "speed_hz"} for c in data["critical_speeds"])
    for speed in speeds_hz:
        i = int(np.argmin(np.abs(np.array(data["speed_hz"]) - speed)))
        assert data["speed_hz"][i] == pytest.approx(speed)
        assert main(["poles", config, "--speed-hz", str(speed), "--json"]) == 0
        rows = json.loads(capsys.readouterr().out)["poles"]
        ours = sorted((m["freq_hz"][i], m["damping_ratio"][i]) for m in data["modes"])
        theirs = sorted((r["freq_hz"], r["damping_ratio"]) for r in rows)
        assert np.allclose(ours, theirs, rtol=1e-9, atol=1e-12)


def test_onset_of_instability_is_seed_003s_threshold():
    """Per-mode whirl iteration over speed vs the threshold iteration of Werner 2017 (Sec. 3)."""
    machine, threshold = machine_threshold(load_config("roller_bearing_stability"))
    n_thr = threshold.speed_rad_s
    cd = campbell_diagram(machine, np.linspace(0.8 * n_thr, 1.2 * n_thr, 9), rule="config")
    onsets = cd.instability_onsets()
    assert len(onsets) == 1
    assert onsets[0]["speed_hz"] * 2 * np.pi == pytest.approx(n_thr, rel=2e-3)
    assert onsets[0]["freq_hz"] * 2 * np.pi == pytest.approx(threshold.whirl_rad_s, rel=2e-3)


def test_open_loop_option_and_report_files(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["campbell", "foot_mount_case3", "--open", "--speed-hz", "0:250:11",
                 "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "loops open" in text and (out / "campbell.png").stat().st_size > 10_000
    saved = json.loads((out / "campbell.json").read_text())
    opened = dataclasses.replace(load_machine("foot_mount_case3"), controllers={})
    cd = campbell_diagram(opened, 2 * np.pi * np.array(saved["speed_hz"]))
    assert np.allclose(sorted(m["freq_hz"][5] for m in saved["modes"]), np.sort(cd.freq_hz[5]))


def test_closed_without_controllers_is_refused(capsys):
    assert main(["campbell", "foot_mount_case1", "--closed", "--speed-hz", "0:10:3"]) == 2
    assert "--closed" in capsys.readouterr().err


def test_every_shipped_machine_has_a_campbell_diagram():
    for name, top_hz in (("foot_mount_case1", 250.0), ("balancer_rigid_rotor", 100.0),
                         ("active_bearing", 500.0), ("sleeve_bearing_motor", 75.0)):
        machine = load_machine(name)
        cd = campbell_diagram(machine, 2 * np.pi * np.linspace(5.0, top_hz, 4))
        assert cd.poles.shape[1] >= 4 and np.all(np.isfinite(cd.poles)), name


def test_campbell_report_renders_in_a_browser(tmp_path):
    out = tmp_path / "c"
    assert main(["campbell", "roller_bearing_stability", "--speed-hz", "300:500:9",
                 "--out", str(out), "--speed-unit", "rpm"]) == 0
    shapes = (out / "index.html").read_text().count('<div class="plot" id="shape')
    # opened in rpm as asked; the selector (here the URL) turns every speed axis to Hz
    assert shapes >= 2 and check_report(out / "index.html", opens_in="rpm") == 2 + shapes


def test_sampled_loop_modes_approach_the_continuous_ones():
    """At the config's 5 kHz control rate the digital loop's equivalent poles s = ln(z)/T lie
    close to the continuous loop's (the sampling contract of DESIGN.md 3, not the same model)."""
    machine = load_machine("foot_mount_case3")
    speeds = 2 * np.pi * np.array([0.0, 100.0, 250.0])
    cont = campbell_diagram(machine, speeds)
    samp = campbell_diagram(machine, speeds, sampled=True)
    for i in range(3):
        low = np.sort(cont.freq_hz[i][cont.freq_hz[i] < 200])
        theirs = np.sort(samp.freq_hz[i][(samp.freq_hz[i] > 1) & (samp.freq_hz[i] < 210)])
        assert theirs.size == low.size
        assert np.allclose(theirs, low, rtol=0.02)
        assert not np.allclose(theirs, low, rtol=1e-6)            # a different model indeed
    # the sampled loop's eigenvectors are tracked by MAC, which needs unit-norm columns
    lam, vec = sampled_poles(machine)(speeds[1], DAMPING_RULES["config"](machine, speeds[1]))
    assert lam.size == vec.shape[1] and vec.shape[0] >= machine.plant.n
    np.testing.assert_allclose(np.linalg.norm(vec, axis=0), 1.0, rtol=1e-12)


def test_a_fine_speed_grid_is_accepted():
    """Steps below 1 rad/s are a grid like any other (only a non-increasing one is refused)."""
    cd = campbell_diagram(disk_machine(), 2 * np.pi * np.array([1.0, 1.05, 1.1]), rule="forced")
    assert cd.poles.shape[0] == 3
    with pytest.raises(ModelError, match="increasing grid"):
        campbell_diagram(disk_machine(), 2 * np.pi * np.array([1.0, 1.0]), rule="forced")
    with pytest.raises(ModelError, match="grid of >= 2 speeds"):
        campbell_diagram(disk_machine(), 2 * np.pi * np.array([1.0]), rule="forced")
