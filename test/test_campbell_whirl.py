"""Whirl direction and mode shapes of the Campbell diagram against rotors whose answer is known:
a gyroscopic disk (the mode whose frequency rises with speed whirls forward, Genta 2005 Sec.
3.6), the analytic orbit of an anisotropic one, a foundation mass that does not whirl, the
declared spin direction of every shipped model against its gyroscopic, circulatory and
unbalance terms, and internal damping destabilising forward whirl only (Werner 2017)."""
import json

import numpy as np
import pytest

from rotor_avc.analysis.campbell import campbell_diagram
from rotor_avc.analysis.stability_study import machine_threshold
from rotor_avc.analysis.mode_shapes import PLANAR_ELLIPTICITY, ROTOR_PAIRS, RotorGeometry
from rotor_avc.cli import main
from rotor_avc.config import load_config
from rotor_avc.machine import MODELS, Machine, load_machine
from rotor_avc.models.plant import LinearPlant
from rotor_avc.reports.campbell_plot import frequency_top

I_D, I_P = 2.0, 1.2                          # kg m^2: disk's transverse and polar inertia
K_X, K_Y = 8.0e5, 8.0e5                      # N m/rad: tilt stiffnesses
M_F, K_F = 40.0, 2.0e7                       # kg, N/m: foundation mass alone (112.5 Hz)


def disk_machine(spin=+1.0, k_y=K_Y):
    """A disk tilting about x and y (``G1[tilt_x, tilt_y] = spin I_p``) and an uncoupled
    foundation mass."""
    gyro = np.zeros((3, 3))
    gyro[0, 1], gyro[1, 0] = spin * I_P, -spin * I_P
    zero = np.zeros((3, 3))
    plant = LinearPlant("disk", ("tilt_x", "tilt_y", "foundation_z"), np.diag([I_D, I_D, M_F]),
                        np.diag([K_X, k_y, K_F]), zero, zero, gyro, zero, (), (), (), 1.0)
    return Machine(load_config("foot_mount_case1"), plant, {})


def pairs_from_gyroscopic(plant):
    """The pair ``(a, b)`` with ``G1[a, b] > 0``: the spin turns from a to b."""
    a, b = np.argwhere(plant.gyroscopic > 0)[0]
    return ((plant.coords[a], plant.coords[b]),)


def whirl_hz(speed_rad_s, sign):
    """Forward (+1) / backward (-1) whirl: I_d w^2 -+ I_p Omega w - k = 0."""
    w = (sign * I_P * speed_rad_s + np.sqrt((I_P * speed_rad_s) ** 2 + 4 * I_D * K_X)) / (2 * I_D)
    return w / (2 * np.pi)


@pytest.mark.parametrize("spin", [+1.0, -1.0])
def test_the_mode_rising_with_speed_whirls_forward(spin):
    machine = disk_machine(spin)
    speeds = 2 * np.pi * np.linspace(0.0, 60.0, 7)
    cd = campbell_diagram(machine, speeds, rule="forced",
                          rotor_pairs=pairs_from_gyroscopic(machine.plant))
    f = cd.freq_hz
    rising = int(np.argmax(f[-1]))
    falling = [k for k in range(3) if k != rising and f[-1, k] < f[0, k]][0]
    foundation = 3 - rising - falling
    assert np.allclose(f[1:, rising], whirl_hz(speeds[1:], +1), rtol=1e-9)
    assert np.allclose(f[1:, falling], whirl_hz(speeds[1:], -1), rtol=1e-9)
    for i in range(1, 7):                               # every speed with a gyroscopic split
        whirl = cd.whirl(i)
        assert (whirl[rising], whirl[falling], whirl[foundation]) == ("forward", "backward", "none")
        assert cd.ellipticity[i, rising] == pytest.approx(1.0, abs=1e-9)      # isotropic: circles
        assert cd.ellipticity[i, falling] == pytest.approx(-1.0, abs=1e-9)
    # at rest the two whirls coincide; the repeated pair is split into its circular modes
    assert sorted(cd.ellipticity[0, [rising, falling]]) == pytest.approx([-1.0, 1.0], abs=1e-9)
    # the spin reversed in the declaration only: the labels swap
    wrong = campbell_diagram(machine, speeds, rule="forced",
                             rotor_pairs=(pairs_from_gyroscopic(machine.plant)[0][::-1],))
    assert wrong.whirl(6)[rising] == "backward"


def test_elliptical_orbit_is_the_analytic_one():
    """Anisotropic tilt stiffness: the orbit of each mode from the null vector of the dynamic
    stiffness ``-w^2 M + j w Omega G1 + K`` (row 1 gives b / a) against the eigenvectors."""
    k_y = 1.3 * K_X
    machine = disk_machine(k_y=k_y)
    speeds = 2 * np.pi * np.array([0.5, 2.0, 10.0, 40.0])
    cd = campbell_diagram(machine, speeds, rule="forced", rotor_pairs=(("tilt_x", "tilt_y"),))
    f_foundation = np.sqrt(K_F / M_F) / (2 * np.pi)
    tilt = [k for k in range(3) if not np.allclose(cd.freq_hz[:, k], f_foundation)]
    for i, speed in enumerate(speeds):
        for k in tilt:
            w = 2 * np.pi * cd.freq_hz[i, k]
            b_over_a = -(K_X - I_D * w ** 2) / (1j * w * I_P * speed)
            fw, bw = abs(1 + 1j * b_over_a), abs(1 - 1j * b_over_a)
            expected = (fw - bw) / (fw + bw)
            assert cd.ellipticity[i, k] == pytest.approx(expected, rel=1e-6, abs=1e-9)
            name = "none" if abs(expected) < PLANAR_ELLIPTICITY else \
                ("forward" if expected > 0 else "backward")
            assert cd.whirl(i)[k] == name
    assert {cd.whirl(0)[k] for k in tilt} == {"none"}            # nearly planar at low speed
    assert {cd.whirl(3)[k] for k in tilt} == {"forward", "backward"}


def _spin_evidence(plant, a, b):
    """Signs saying the spin turns from a to b: ``G1[a, b]``, ``N_eta[a, b]`` and the
    rotating unbalance force ``p2[b] = -j p2[a]``, where the plant has them."""
    signs = [np.sign(m[a, b]) for m in (plant.gyroscopic, plant.circulatory) if m[a, b] != 0]
    for exc in plant.excitations:
        if exc.p2[a] != 0 and exc.p2[b] != 0:
            ratio = exc.p2[b] / exc.p2[a]
            assert abs(abs(ratio) - 1) < 1e-12 and abs(ratio.real) < 1e-12, exc.name
            signs.append(-np.sign(ratio.imag))
    return signs


@pytest.mark.parametrize("config", ["foot_mount_case3", "roller_bearing_stability",
                                    "sleeve_bearing_motor", "active_bearing",
                                    "balancer_rigid_rotor"])
def test_declared_spin_agrees_with_each_models_physics(config):
    machine = load_machine(config)
    geometry = RotorGeometry.of_machine(machine)
    assert len(geometry.pairs) == len(ROTOR_PAIRS[machine.config.raw("model")]) == 2
    evidence = [s for a, b in geometry.pairs for s in _spin_evidence(machine.plant, a, b)]
    assert evidence and all(s > 0 for s in evidence), evidence
    assert all(part.startswith(("rotor", "machine", "journal")) for i in np.ravel(geometry.pairs)
               for part in [geometry.parts[i][0]])


def test_every_model_declares_its_rotor_pairs():
    assert set(ROTOR_PAIRS) == set(MODELS)


def test_gyroscopic_split_of_the_active_bearings_rotor():
    """Sci. Rep. 2023's rigid shaft (gyroscopic): of each pair of tilting modes the one rising
    with speed is labelled forward, the falling one backward, at every speed."""
    cd = campbell_diagram(load_machine("active_bearing"), 2 * np.pi * np.linspace(0.0, 500.0, 6))
    f = cd.freq_hz
    slope = f[-1] - f[1]
    split = [k for k in range(f.shape[1]) if abs(slope[k]) > 1e-4 * f[-1, k]
             and np.all(np.sign(np.diff(f[1:, k])) == np.sign(slope[k]))]
    assert len(split) >= 4 and sum(slope[split] > 0) == sum(slope[split] < 0)
    for i in range(1, 6):
        for k in split:
            assert cd.whirl(i)[k] == ("forward" if slope[k] > 0 else "backward"), (i, cd.labels[k])


def test_internal_damping_destabilises_a_forward_whirl():
    """Rotating internal damping feeds forward whirl above the critical speed only (Werner 2017
    Sec. 3; Genta 2005 Sec. 5.4): the mode whose onset the diagram finds whirls forward there."""
    machine, threshold = machine_threshold(load_config("roller_bearing_stability"))
    cd = campbell_diagram(machine, np.linspace(0.8, 1.2, 9) * threshold.speed_rad_s)
    onsets = cd.instability_onsets()
    assert onsets
    k = cd.labels.index(onsets[0]["mode"])
    after = int(np.searchsorted(cd.speed_hz, onsets[0]["speed_hz"]))
    assert cd.whirl(after)[k] == "forward"
    assert cd.ellipticity[after, k] > 0.2


def test_json_shapes_axis_and_damping_rule(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["campbell", "foot_mount_case3", "--speed-hz", "0:250:26", "--running-hz", "100",
                 "--json", "--out", str(out)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["reference_speed_hz"] == pytest.approx(100.0)
    assert "w_F = the whirl frequency of mode 6" in data["damping_rule"]
    assert "Werner 2021 Fig. 4" in data["damping_rule"]
    coords = load_machine("foot_mount_case3").plant.coords
    for mode in data["modes"]:
        assert mode["whirl"] in ("forward", "backward", "none")
        mags = [r["magnitude"] for r in mode["shape"]]
        assert max(mags) == pytest.approx(1.0) and min(mags) >= 0.05
        top = mode["shape"][int(np.argmax(mags))]
        assert top["phase_deg"] == 0.0 and {r["coordinate"] for r in mode["shape"]} <= set(coords)
        assert all(-180.0 <= r["phase_deg"] <= 180.0 for r in mode["shape"])
    saved = json.loads((out / "campbell.json").read_text())
    assert saved["damping_rule"] == data["damping_rule"] and saved["modes"] == data["modes"]
    # the frequency axis: 1.2 x the highest mode below the top speed (196.3 Hz), under the 2x top
    cd = campbell_diagram(load_machine("foot_mount_case3"), 2 * np.pi * np.linspace(0, 250, 26))
    below = cd.freq_hz[:, cd.freq_hz.min(axis=0) <= 250.0]
    assert frequency_top(cd) == pytest.approx(1.2 * below.max())
    assert 200.0 < frequency_top(cd) < 2 * 250.0
    assert cd.caption(2, 10) == "mode 3, 15.96 Hz, FW"
    page = (out / "index.html").read_text()
    lowest = cd.freq_hz.min(axis=0)
    shown = int(np.sum((lowest > 0) & (lowest <= frequency_top(cd))))
    assert page.count('<div class="plot" id="shape') == shown == 12
    assert "mode 3, 15.96 Hz, FW" in page and '"sliders"' in page


def test_running_speed_outside_the_grid_is_refused(capsys):
    assert main(["campbell", "foot_mount_case1", "--speed-hz", "0:10:3", "--running-hz", "20"]) == 2
    assert "--running-hz" in capsys.readouterr().err


def test_terminal_table_has_whirl_and_dominant_coordinates(capsys):
    assert main(["campbell", "sleeve_bearing_motor", "--speed-hz", "5:75:8"]) == 0
    text = capsys.readouterr().out
    assert "per-mode iteration, Werner 2019 Sec. 3.3" in text.splitlines()[0]
    row = [line for line in text.splitlines() if line.strip().startswith("mode 3 (")][0]
    assert row.split()[7:] == ["forward", "rotor", "y/z,", "journal", "y/z"]
