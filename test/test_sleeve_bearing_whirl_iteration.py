"""The per-mode whirl-frequency iteration (rotor_avc.analysis.whirl_iteration) on systems with a
closed-form answer, on near-degenerate modes, and as the Werner 2019 config's pole method."""
import math

import numpy as np
import pytest

from rotor_avc.closed_loop.loop import ClosedLoop
from rotor_avc.analysis.poles import machine_poles
from rotor_avc.analysis.whirl_iteration import per_mode_poles
from rotor_avc.errors import ModelError
from rotor_avc.machine import load_machine
from rotor_avc.models.plant import LinearPlant


def oscillators(masses, stiffnesses, loss_factor, coupling=0.0):
    """Independent (or weakly coupled) oscillators with hysteretic damping c tan(delta) / w_F."""
    n = len(masses)
    C = np.diag(stiffnesses).astype(float)
    if n > 1:
        C[0, -1] = C[-1, 0] = -coupling
    return LinearPlant("osc", tuple(f"x{i}" for i in range(n)), np.diag(masses).astype(float), C,
                       loss_factor * np.diag(stiffnesses).astype(float), np.zeros((n, n)),
                       np.zeros((n, n)), np.zeros((n, n)), (), (), (), 2 * np.pi)


@pytest.mark.parametrize("eta", [0.04, 0.3, 0.8])
def test_single_oscillator_closed_form(eta):
    """m x'' + (c eta / w) x' + c x = 0 with w = Im(lambda): w^2 = c/m (1 + sqrt(1 - eta^2)) / 2,
    Re(lambda) = -c eta / (2 m w) -- the lightly damped fixed point, also from a start speed
    where the loss-factor damping at w_F = Omega overdamps the mode."""
    m, c = 2.0, 2.0e4
    w = math.sqrt(c / m * (1 + math.sqrt(1 - eta**2)) / 2)
    for speed in (5.0, 50.0, 500.0):
        res = per_mode_poles(ClosedLoop(oscillators([m], [c], eta)), speed)
        upper = res.poles[res.poles.imag > 0]
        assert upper.size == 1 and res.poles.size == 2
        assert upper[0] == pytest.approx(complex(-c * eta / (2 * m * w), w), rel=1e-5)
        assert res.w_F[res.poles.imag > 0][0] == pytest.approx(w, rel=1e-6)


def test_near_degenerate_modes_stay_apart():
    """Two nearly equal oscillators (0.03 % apart, weakly coupled): each pair keeps its own
    converged eigenvalue (plain nearest-eigenvalue iteration hops between them)."""
    plant = oscillators([40.0, 40.0], [2.70e8, 2.7008e8], 0.04, coupling=1e3)
    res = per_mode_poles(ClosedLoop(plant), 120.0)
    upper = np.sort_complex(res.poles[res.poles.imag > 0])
    assert upper.size == 2 and abs(upper[1] - upper[0]) > 0.3
    for lam, w_F in zip(res.poles, res.w_F):
        A, _ = ClosedLoop(plant).state_space(120.0, w_F)
        assert np.min(np.abs(np.linalg.eigvals(A) - lam)) < 1e-6 * abs(lam)


def test_every_pole_is_a_fixed_point_of_the_seed001_loop():
    machine = load_machine("sleeve_bearing_motor_velocity")
    speed = 2390 * math.pi / 30
    res = per_mode_poles(machine.loop, speed)
    assert res.poles.size == 2 * machine.plant.n
    floor = machine.plant.damping_floor_rad_s
    assert np.allclose(np.maximum(np.abs(res.poles.imag), floor), res.w_F, rtol=1e-5)
    for lam, w_F in zip(res.poles[::3], res.w_F[::3]):
        A, _ = machine.loop.state_space(speed, w_F)
        assert np.min(np.abs(np.linalg.eigvals(A) - lam)) < 1e-6 * max(abs(lam), 1.0)
    pr = machine_poles(machine, speed)                  # analysis.pole_method: whirl_iteration
    assert pr.stable and np.allclose(np.sort_complex(pr.poles), np.sort_complex(res.poles))


def test_refusals():
    with pytest.raises(ModelError, match="tolerance"):
        per_mode_poles(ClosedLoop(oscillators([1.0], [1e4], 0.04)), 10.0, rel_tol=0.0)
    machine = load_machine("sleeve_bearing_motor")
    with pytest.raises(ModelError, match="tabulated for"):
        machine_poles(machine, 0.0)                     # no oil film at standstill
