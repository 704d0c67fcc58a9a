"""The Campbell diagram's contract at its edges (rotor_avc.analysis.campbell), each against a
hand computation: a critical speed below 1 Hz and one met exactly at a grid speed, the default
orders and reference speed, the log decrement of a non-oscillating pole of either sign, and the
circular whirl of a repeated pair at every speed up to the highest."""
import numpy as np
import pytest

from rotor_avc.analysis.campbell import CampbellDiagram, _crossings, campbell_diagram
from rotor_avc.config import load_config
from rotor_avc.machine import Machine
from rotor_avc.models.plant import LinearPlant

I_D, K_T = 2.0, 8.0e5                    # kg m^2, N m/rad: tilt modes at 100.7 Hz
M_Z, F_Z = 10.0, 0.5                     # kg, Hz: a soft translation mode


def machine(polar_inertia=0.0, loss_factor=0.0):
    """A disk tilting about x and y (gyroscopic ``I_p``) and an uncoupled translation of
    ``F_Z`` Hz, with loss-factor damping (``eta K / w_F``, ``w_F = max(Omega, 1 rad/s)``)."""
    gyro = np.zeros((3, 3))
    gyro[0, 1], gyro[1, 0] = polar_inertia, -polar_inertia
    zero = np.zeros((3, 3))
    k_z = M_Z * (2 * np.pi * F_Z) ** 2
    stiff = np.diag([K_T, K_T, k_z])
    plant = LinearPlant("disk", ("tilt_x", "tilt_y", "z"), np.diag([I_D, I_D, M_Z]), stiff,
                        loss_factor * stiff, zero, gyro, zero, (), (), (), 1.0)
    return Machine(load_config("foot_mount_case1"), plant, {})


PAIRS = (("tilt_x", "tilt_y"),)


def test_a_critical_speed_below_1_hz_and_the_default_orders_and_reference():
    speeds = 2 * np.pi * np.linspace(0.0, 2.0, 9)
    cd = campbell_diagram(machine(), speeds, rule="forced", rotor_pairs=PAIRS)
    # the 0.5 Hz translation meets 1x at 0.5 Hz and 2x at 0.25 Hz; the tilt modes (100.7 Hz)
    # lie far above both lines
    rows = cd.critical_speeds()
    assert [(r["order"], r["speed_hz"]) for r in rows] == [(2, pytest.approx(0.25, abs=1e-9)),
                                                            (1, pytest.approx(0.5, abs=1e-9))]
    assert {r["mode"] for r in rows} == {"mode 1 (0.5 Hz)"}
    out = cd.to_json()
    assert out["reference_speed_hz"] == pytest.approx(2.0, abs=1e-12)     # the highest speed
    assert out["critical_speeds"] == rows


def test_a_mode_met_exactly_at_a_grid_speed_is_one_critical_speed():
    x = np.array([0.0, 1.0, 2.0, 3.0])
    valid = np.ones(4, bool)
    # falling through zero at a grid point (f - s: 1, 0, -1) and rising through it (-1, 0, 1)
    assert _crossings(x, np.array([1.0, 0.5, 0.0, -1.0]), valid) == pytest.approx([2.0])
    assert _crossings(x, np.array([-1.0, -0.5, 0.0, 1.0]), valid) == pytest.approx([2.0])
    assert _crossings(x, np.array([-1.0, -0.5, 0.0, 1.0]), valid, rising_only=True) \
        == pytest.approx([2.0])
    assert _crossings(x, np.array([1.0, 0.5, 0.0, -1.0]), valid, rising_only=True) == []


def test_the_log_decrement_of_a_non_oscillating_pole_is_infinite_whatever_its_sign():
    poles = np.array([[-3.0 + 0j, 2.0 + 0j, -1.0 + 20.0j, -0.1 + 0.5j]])
    cd = CampbellDiagram(np.array([0.0]), poles, ["a", "b", "c", "d"], np.zeros((1, 4, 4)), None)
    # -2 pi Re / |Im| for the oscillating poles: 2 pi / 20, and 2 pi 0.1 / 0.5 (a slow one)
    np.testing.assert_allclose(cd.log_decrement[0], [np.inf, np.inf, 2 * np.pi / 20.0,
                                                     2 * np.pi * 0.2])
    np.testing.assert_allclose(cd.damping_ratio[0], [1.0, -1.0, 1.0 / np.hypot(1.0, 20.0),
                                                     0.1 / np.hypot(0.1, 0.5)])


def test_critical_speeds_of_oscillating_modes_only():
    """A mode at 5 Hz at rest, overdamped (non-oscillating) at 1 Hz and at 10 Hz at 2 Hz: its
    1x line ``f - s`` goes 5, -1, 8, but only between oscillating points does a sign change
    count -- no critical speed; the other mode, 1.5 Hz throughout, meets 1x at 1.5 Hz."""
    poles = np.array([[-1.0 + 10j * np.pi, -0.1 + 3j * np.pi],
                      [-5.0 + 0j, -0.1 + 3j * np.pi],
                      [-1.0 + 20j * np.pi, -0.1 + 3j * np.pi]])
    cd = CampbellDiagram(2 * np.pi * np.array([0.0, 1.0, 2.0]), poles, ["slow", "steady"],
                         np.zeros((3, 2, 2)), None)
    assert cd.critical_speeds((1,)) == [{"mode": "steady", "order": 1,
                                         "speed_hz": pytest.approx(1.5, abs=1e-12)}]


@pytest.mark.parametrize("loss_factor", [0.0, 1e-4])
def test_a_repeated_pair_whirls_circularly_at_every_speed_up_to_the_highest(loss_factor):
    """Without gyroscopic coupling an isotropic disk's tilt modes coincide at every speed
    (damped by ``eta K / w_F``: their frequency changes with speed): each pair is split into
    its forward and backward circular whirl (ellipticity +1 and -1), at the highest speed too,
    where whirl and shapes are reported by default, each column keeping its whirl."""
    speeds = 2 * np.pi * np.linspace(0.0, 60.0, 7)
    cd = campbell_diagram(machine(loss_factor=loss_factor), speeds, rule="forced",
                          rotor_pairs=PAIRS)
    tilt = [k for k in range(3) if cd.freq_hz[0, k] > 50.0]
    e = cd.ellipticity[:, tilt]
    assert sorted(e[-1]) == pytest.approx([-1.0, 1.0], abs=1e-9)
    np.testing.assert_allclose(e, np.broadcast_to(e[-1], e.shape), atol=1e-9)
    assert sorted(cd.to_json()["modes"][k]["whirl"] for k in tilt) == ["backward", "forward"]


@pytest.mark.parametrize("n_speeds", [2, 5])
def test_at_rest_the_split_pair_continues_the_whirl_of_its_columns(n_speeds):
    """A gyroscopic disk: at rest its two tilt whirls coincide; each column of the pair takes
    the circular mode that the same column has at the next speed (forward stays forward)."""
    speeds = 2 * np.pi * np.linspace(0.0, 60.0, n_speeds)
    cd = campbell_diagram(machine(polar_inertia=1.2), speeds, rule="forced", rotor_pairs=PAIRS)
    tilt = [k for k in range(3) if cd.freq_hz[0, k] > 50.0]
    e = cd.ellipticity[:, tilt]
    assert sorted(e[1]) == pytest.approx([-1.0, 1.0], abs=1e-9)
    np.testing.assert_allclose(e, np.broadcast_to(e[1], e.shape), atol=1e-9)
