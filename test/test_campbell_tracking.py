"""Campbell mode tracking by the modal assurance criterion (rotor_avc.analysis.campbell): a damped
crossing of two modes of different shape that eigenvalue continuity alone resolves wrongly, and
the tracking cost against a hand computation of MAC (Allemang 2003, eq. 1) and the relative
eigenvalue distance."""
import numpy as np
import pytest
import scipy.optimize

from rotor_avc.analysis.campbell import CampbellDiagram, _crossings, tracking_cost

#: the two shapes: orthogonal, neither along a coordinate axis
SHAPES = np.array([[1.0, 1.0], [1.0, -1.0]]) / np.sqrt(2)
ZETA = 0.02


def state_matrix(speed):
    """Two damped modes, shapes SHAPES[:, 0] and SHAPES[:, 1], whose natural frequencies
    10 + speed and 14 - speed (rad/s) cross at speed 2 (a 4x4 first-order system)."""
    w = np.array([10.0 + speed, 14.0 - speed])
    k = SHAPES @ np.diag(w ** 2) @ SHAPES.T
    c = SHAPES @ np.diag(2 * ZETA * w) @ SHAPES.T
    return np.block([[np.zeros((2, 2)), np.eye(2)], [-k, -c]])


def tracked(speeds, cost):
    """Follow the poles over ``speeds`` as campbell_diagram does, with ``cost``: the upper
    half-plane poles' frequencies, columns in the order of the first speed."""
    rows, prev = [], None
    for speed in speeds:
        lam, vec = np.linalg.eig(state_matrix(speed))
        vec = vec / np.linalg.norm(vec, axis=0)
        if prev is None:
            order = np.argsort(lam.imag)
            lam, vec = lam[order], vec[:, order]
        else:
            _, cols = scipy.optimize.linear_sum_assignment(cost(*prev, lam, vec))
            lam, vec = lam[cols], vec[:, cols]
        rows.append(lam)
        prev = (lam, vec)
    poles = np.array(rows)
    return poles[:, poles[0].imag > 0]


def eigenvalue_distance(lam_a, vec_a, lam_b, vec_b):
    return np.abs(lam_a[:, None] - lam_b[None, :])


def test_a_crossing_resolved_only_by_the_mode_shapes():
    speeds = [1.5, 1.9, 2.3, 2.7]               # 11.9/12.1 rad/s at 1.9, 12.3/11.7 at 2.3
    w = np.array([[10.0 + s, 14.0 - s] for s in speeds])
    damped = w * np.sqrt(1 - ZETA ** 2)
    by_shape = tracked(speeds, tracking_cost)
    np.testing.assert_allclose(np.sort(by_shape.imag, axis=1), np.sort(damped, axis=1), rtol=1e-9)
    # each column keeps its mode: one rises through the crossing, the other falls
    np.testing.assert_allclose(by_shape.imag, damped, rtol=1e-9)
    np.testing.assert_allclose(by_shape.real, -ZETA * w, rtol=1e-9)
    # eigenvalue continuity alone swaps them at the crossing (the test above is not vacuous)
    by_value = tracked(speeds, eigenvalue_distance)
    assert not np.allclose(by_value.imag, damped, rtol=1e-3)


def test_tracking_cost_is_one_minus_mac_plus_the_relative_distance():
    u = np.array([[1.0, 0.0], [0.0, 1.0]], complex)
    v = np.array([[1.0, 1.0j], [1.0, 0.0]], complex) / np.array([np.sqrt(2), 1.0])
    lam_a = np.array([-0.1 + 0.5j, -1.0 + 4.0j])
    lam_b = np.array([-0.1 + 0.6j, -1.0 + 3.0j])
    # MAC by hand: u1.v1 -> 1/2, u1.v2 -> |1j|^2 = 1, u2.v1 -> 1/2, u2.v2 -> 0
    mac = np.array([[0.5, 1.0], [0.5, 0.0]])
    dist = np.array([[0.1 / 1.0,                      # both |lambda| < 1: scale 1
                      abs(-0.9 + 2.5j) / abs(-1.0 + 3.0j)],
                     [abs(-0.9 + 3.4j) / abs(-1.0 + 4.0j), 1.0 / abs(-1.0 + 4.0j)]])
    np.testing.assert_allclose(tracking_cost(lam_a, u, lam_b, v), 1.0 - mac + dist, rtol=1e-12)


def test_crossings_interpolate_sign_changes():
    x = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    g = np.array([-1.0, 1.0, 3.0, -1.0, 0.0])
    valid = np.ones(5, bool)
    # a touch of zero from below (-1 -> 0) counts as a crossing
    assert _crossings(x, g, valid) == pytest.approx([0.5, 2.75, 4.0])
    assert _crossings(x, g, valid, rising_only=True) == pytest.approx([0.5, 4.0])
    valid[1] = False                            # a crossing next to an invalid point is not one
    assert _crossings(x, g, valid) == pytest.approx([2.75, 4.0])
    # a touch of zero from above counts once: 1 -> 0 -> -1 crosses at 1
    assert _crossings(x[:3], np.array([1.0, 0.0, -1.0]), valid[2:]) == pytest.approx([1.0])


def test_damping_measures_of_oscillating_and_real_poles():
    """zeta = -Re / |lambda|; log decrement -2 pi Re / |Im|, infinite for a real pole (also an
    unstable one: it does not oscillate)."""
    poles = np.array([[-1.0 + 10.0j, -2.0 + 0.0j, 3.0 + 0.0j, 0.5 - 4.0j]])
    cd = CampbellDiagram(np.array([0.0]), poles, ["a", "b", "c", "d"], np.zeros((1, 1, 4)), None)
    np.testing.assert_allclose(cd.log_decrement[0], [2 * np.pi / 10, np.inf, np.inf,
                                                     -2 * np.pi * 0.5 / 4])
    np.testing.assert_allclose(cd.damping_ratio[0], [1 / np.sqrt(101), 1.0, -1.0,
                                                     -0.5 / np.sqrt(16.25)])
    np.testing.assert_allclose(cd.freq_hz[0], np.array([10.0, 0.0, 0.0, 4.0]) / (2 * np.pi))


def test_critical_speeds_and_the_reference_speed():
    """Modes of constant 10 Hz and 0.5 Hz over 0..30 Hz: order 1 meets them at 10 and 0.5 Hz,
    order 2 at 5 and 0.25 Hz (hand computation, linear between grid speeds)."""
    speed_hz = np.linspace(0.0, 30.0, 121)
    poles = np.tile(2j * np.pi * np.array([10.0, 0.5]) - 0.1, (speed_hz.size, 1))
    cd = CampbellDiagram(2 * np.pi * speed_hz, poles, ["mode 1", "mode 2"],
                         np.zeros((speed_hz.size, 1, 2)), None)
    rows = [(r["mode"], r["order"], round(r["speed_hz"], 9)) for r in cd.critical_speeds()]
    assert rows == [("mode 2", 2, 0.25), ("mode 2", 1, 0.5), ("mode 1", 2, 5.0),
                    ("mode 1", 1, 10.0)]
    assert cd.reference_index(None) == speed_hz.size - 1 and cd.reference_index(10.1) == 40
