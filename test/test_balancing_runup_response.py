"""Zhou & Shi 2001 App. A: the closed-form run-up response against numerical integration, its stated
structure (K jump, small transient), the digest's M_k test vector, and the rigid-rotor
LinearPlant against the steady-state limit."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rotor_avc.closed_loop.frf import unbalance_frf
from rotor_avc.closed_loop.loop import ClosedLoop
from rotor_avc.balancing.runup_response import runup_response, sudden_onset_time
from rotor_avc.config import load_config
from rotor_avc.errors import ModelError
from rotor_avc.machine import load_machine
from rotor_avc.model_config.rigid_rotor import rotor_from_config

ROTOR = rotor_from_config(load_config("balancer_rigid_rotor"))


def integrate(t, w_n, zeta, alpha, omega0):
    """Eq. (A1) with zero initial state by DOP853 at tight tolerances."""
    def f(tt, y):
        x, v = y[0] + 1j * y[1], y[2] + 1j * y[3]
        om = omega0 + alpha * tt
        a = -2 * zeta * w_n * v - w_n**2 * x + (om**2 - 1j * alpha) * np.exp(
            1j * (omega0 * tt + alpha * tt**2 / 2))
        return [v.real, v.imag, a.real, a.imag]
    sol = solve_ivp(f, (0, t[-1]), [0, 0, 0, 0], t_eval=t, rtol=1e-11, atol=1e-12,
                    method="DOP853")
    return sol.y[0] + 1j * sol.y[1], sol.y[2] + 1j * sol.y[3]


@pytest.mark.parametrize("w_n, zeta, alpha, omega0, t_end", [
    (ROTOR.omega_n[0], ROTOR.zeta[0], 300.0, 0.0, 3.0),     # the paper's translational mode
    (ROTOR.omega_n[1], ROTOR.zeta[1], 300.0, 0.0, 4.0),     # conical mode
    (200.0, 0.05, 1500.0, 50.0, 0.4),                        # another set, started spinning
])
def test_closed_form_matches_integration(w_n, zeta, alpha, omega0, t_end):
    t = np.linspace(0, t_end, 1501)
    parts = runup_response(t, w_n, zeta, alpha, omega0)
    x, v = integrate(t, w_n, zeta, alpha, omega0)
    assert np.abs(parts.total - x).max() <= 1e-5 * np.abs(x).max()
    assert np.abs(parts.velocity - v).max() <= 1e-5 * np.abs(v).max()


def test_sudden_part_appears_at_t_K_and_transient_is_small():
    w, z = ROTOR.omega_n[0], ROTOR.zeta[0]
    t_K = sudden_onset_time(w, z, 300.0)
    assert t_K == pytest.approx(1.91814, abs=1e-5)              # digest 8
    t = np.linspace(0, 4, 4001)
    p = runup_response(t, w, z, 300.0)
    assert np.all(p.M_n[t < t_K] == 0) and np.all(p.M_n[t > t_K + 1e-3] > 0)
    # after t_K the sudden part is a free vibration at w_d decaying like e^{-zeta w_n t}
    k = (t > t_K + 0.01)
    ratio = np.abs(p.sudden[k]) * np.exp(z * w * t[k])
    assert np.ptp(ratio) <= 1e-9 * ratio.max()
    # part 1 "usually very small" (paper): digest 9.2e-4 against a peak of 33.9
    assert np.abs(p.transient).max() == pytest.approx(9.2e-4, rel=0.01)
    assert np.abs(p.total).max() == pytest.approx(33.887, rel=1e-4)


def test_modal_amplifications_digest_vector():
    t = np.array([1.0, 2.0, 2.4, 2.9506, 3.3, 3.6, 4.0])
    M1_ref = [0.3805, 37.8972, 8.1748, 2.2929, 1.6385, 1.4295, 1.3011]
    M2_ref = [0.1045, 0.6089, 1.1970, 4.5857, 66.1549, 6.5000, 2.9500]
    Mn2_ref = [0, 0, 0, 0, 39.0454, 1.1039, 0.0095]
    p1 = runup_response(t, ROTOR.omega_n[0], ROTOR.zeta[0], 300.0)
    p2 = runup_response(t, ROTOR.omega_n[1], ROTOR.zeta[1], 300.0)
    # the digest prints 4 decimals
    np.testing.assert_allclose(p1.M, M1_ref, rtol=0, atol=5.1e-5)
    np.testing.assert_allclose(p2.M, M2_ref, rtol=0, atol=5.1e-5)
    np.testing.assert_allclose(p2.M_n, Mn2_ref, rtol=0, atol=5.1e-5)


def test_slow_runup_tends_to_the_steady_state_response():
    """As alpha -> 0 the synchronous part is the steady-state magnification."""
    w_n, zeta, alpha = 500.0, 0.02, 5.0
    t = np.array([40.0, 80.0, 140.0])                      # 200, 400, 700 rad/s
    om = alpha * t
    steady = om**2 / np.abs(w_n**2 - om**2 + 2j * zeta * w_n * om)
    assert runup_response(t, w_n, zeta, alpha).M_s == pytest.approx(steady, rel=2e-3)


def test_bad_inputs_are_refused():
    with pytest.raises(ModelError, match="acceleration"):
        runup_response([0.1], 500.0, 0.02, 0.0)
    with pytest.raises(ModelError, match="underdamped"):
        runup_response([0.1], 500.0, 1.2, 100.0)


def test_rigid_rotor_plant_matches_paper_modes_and_steady_state():
    machine = load_machine("balancer_rigid_rotor")
    plant = machine.plant
    assert ROTOR.mass_kg == pytest.approx(245.0442, rel=1e-6)        # digest 5
    assert ROTOR.omega_n == pytest.approx([571.3770, 975.1351], rel=1e-6)
    assert ROTOR.zeta == pytest.approx([0.0071422, 0.0121892], rel=1e-4)
    speeds = np.array([300.0, 571.0, 900.0])
    frf = unbalance_frf(ClosedLoop(plant), speeds)
    # static unbalance u = m_u (u_x - j u_z): R = u Omega^2 / (m (w1^2 - Omega^2 + 2j zeta w1 Omega))
    w1, z1 = ROTOR.omega_n[0], ROTOR.zeta[0]
    H1 = speeds**2 / (ROTOR.mass_kg * (w1**2 - speeds**2 + 2j * z1 * w1 * speeds))
    np.testing.assert_allclose(frf.responses["output_x_static"], H1, rtol=1e-10)
    np.testing.assert_allclose(frf.responses["output_z_static"], 1j * H1, rtol=1e-10)
    # moment unbalance per kg m^2 at l_s = 0.5: X = -l_s psi, psi = -theta-mode response
    w2, z2 = ROTOR.omega_n[1], ROTOR.zeta[1]
    H2 = speeds**2 / (ROTOR.I_t * (w2**2 - speeds**2 + 2j * z2 * w2 * speeds))
    np.testing.assert_allclose(frf.responses["output_x_moment"], 0.5 * H2, rtol=1e-10)
