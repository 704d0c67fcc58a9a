"""The modal route for FRFs over speed against the direct solve of Z(j Omega) q = F."""
import numpy as np
import pytest

from rotor_avc.closed_loop import modal_frf
from rotor_avc.closed_loop.loop import ClosedLoop
from rotor_avc.closed_loop.frf import unbalance_frf
from rotor_avc.control.spec import i_controller
from rotor_avc.machine import load_machine


def direct(loop, speeds, w_F=None):
    """Every coordinate's response by the batched solve, per excitation."""
    w_F = loop.plant.forced_damping_frequency(speeds) if w_F is None else w_F
    F = np.stack([e.phasor(speeds) for e in loop.plant.excitations], axis=-1)
    return np.linalg.solve(loop.dynamic_stiffness(1j * speeds, speeds, w_F), F)


def assert_equal_to_peak(Q, ref, tol=1e-9):
    for j in range(ref.shape[2]):
        for i in range(ref.shape[1]):
            peak = np.abs(ref[:, :, j]).max()
            assert np.abs(Q[:, i, j] - ref[:, i, j]).max() <= tol * peak


@pytest.mark.parametrize("config", ["foot_mount_case2", "foot_mount_case3", "active_bearing",
                                    "roller_bearing_stability", "balancer_rigid_rotor"])
def test_quadratic_coefficients_are_the_dynamic_stiffness(config):
    loop = load_machine(config).loop
    K0, K1, K2 = modal_frf.quadratic_coefficients(loop)
    speeds = np.array([3.7, 120.0, 1900.0])
    Z = loop.dynamic_stiffness(1j * speeds, speeds, speeds)
    poly = K0 + speeds[:, None, None] * K1 + speeds[:, None, None] ** 2 * K2
    assert np.allclose(poly, Z, rtol=1e-12, atol=1e-12 * np.abs(Z).max())


@pytest.mark.parametrize("config, top_hz", [("foot_mount_case2", 250.0), ("foot_mount_case3", 250.0),
                                            ("active_bearing", 1000.0),
                                            ("roller_bearing_stability", 600.0)])
def test_modal_route_equals_the_direct_solve(config, top_hz):
    loop = load_machine(config).loop
    speeds = 2 * np.pi * np.linspace(1.5, top_hz, 1200)
    assert modal_frf.ModalStiffness.of(loop) is not None
    F = np.stack([e.phasor(speeds) for e in loop.plant.excitations], axis=-1)
    Q = modal_frf.solve_over_speed(loop, speeds, speeds.copy(), F)
    assert_equal_to_peak(Q, direct(loop, speeds))


def test_speeds_below_the_damping_floor_take_the_direct_solve():
    loop = load_machine("foot_mount_case3").loop
    speeds = 2 * np.pi * np.linspace(0.05, 250.0, 800)       # floor 1 Hz: w_F != Omega below
    w_F = loop.plant.forced_damping_frequency(speeds)
    assert np.any(w_F != speeds)
    F = np.stack([e.phasor(speeds) for e in loop.plant.excitations], axis=-1)
    assert_equal_to_peak(modal_frf.solve_over_speed(loop, speeds, w_F, F), direct(loop, speeds))


def test_routes_chosen_automatically():
    plant = load_machine("foot_mount_case2").plant
    with_states = ClosedLoop(plant, {"DL": i_controller(2.0e6, "displacement")})
    assert modal_frf.quadratic_coefficients(with_states) is None          # controller states
    assert modal_frf.quadratic_coefficients(load_machine("sleeve_bearing_motor").loop) is None
    speeds = 2 * np.pi * np.linspace(2.0, 250.0, 400)
    frf = unbalance_frf(with_states, speeds)                               # batched solve
    ref = np.linalg.solve(with_states.dynamic_stiffness(1j * speeds, speeds, speeds),
                          plant.excitation("static").phasor(speeds)[..., None])[:, :, 0]
    row = plant.output("bearing_D_vz").row
    assert np.allclose(frf.responses["bearing_D_vz_static"], 1j * speeds * (ref @ row), rtol=1e-12)


def test_unbalance_frf_is_the_same_on_both_routes(monkeypatch):
    loop = load_machine("foot_mount_case3").loop
    speeds = 2 * np.pi * np.linspace(1.0, 250.0, 500)
    modal = unbalance_frf(loop, speeds)
    monkeypatch.setattr(modal_frf, "MODAL_MIN_SPEEDS", 10**9)
    batched = unbalance_frf(loop, speeds)
    top = max(np.abs(v).max() for v in batched.responses.values())
    for key, ref in batched.responses.items():
        peak = np.abs(ref).max()
        if peak > 1e-9 * top:                  # not zero by symmetry (round-off only)
            assert np.abs(modal.responses[key] - ref).max() <= 1e-9 * peak, key
