"""Loop margins (rotor_avc.analysis.loop_margins) against independent references.

(a) python-control's ``stability_margins`` and ``disk_margins`` on the same loops built in this
    file from the plant matrices (continuous: ``control.ss`` of M, D, C and the foot rows;
    sampled: scipy's ZOH ``cont2discrete`` with the acceleration's feed-through of the force held
    over the last interval, DESIGN.md section 3), the other loops closed by ``control.feedback``;
(b) the all-loop gain margin from the frequency response against the eigenvalue bisection
    (``SampledLoop.stable_gain_range``, and of ``ClosedLoop.state_space`` for a continuous case);
(c) closed forms: a mass on a spring and damper under I control on displacement, a free mass
    under P control on velocity sampled with a zero-order hold.
"""
import math

import control
import numpy as np
import pytest
import scipy.signal

from rotor_avc.analysis.loop_margins import (analyse_loop, continuous_loop_frf, gain_margin_frf,
                                             loop_margins, sampled_loop_frf)
from rotor_avc.analysis.poles import machine_poles
from rotor_avc.analysis.sampled_loop import SampledLoop, machine_sampled_loop
from rotor_avc.closed_loop.loop import ClosedLoop
from rotor_avc.control.discretize import discretize_controller
from rotor_avc.control.spec import ContinuousController, i_controller, p_controller
from rotor_avc.machine import load_machine
from rotor_avc.models.plant import Actuator, Excitation, LinearPlant

CASES = [("foot_mount_case3", 0.0), ("foot_mount_case3", 25.0),
         ("sleeve_bearing_motor_velocity", 10.0), ("sleeve_bearing_motor_velocity", 25.0)]
RATES_HZ = (1000.0, 5000.0)
#: python-control's FRD margins are brentq roots on a spline through a pole-refined grid of the
#: same loop: they agree to about 1e-7; the bar leaves a decade
RTOL = 1e-6
#: Ms and the disk margin: bounded maximisation (here) against python-control's grid / brent
RTOL_PEAK = 1e-4
#: the eigenvalue bisection stops at g_out / g_in - 1 <= 1e-3 and returns the geometric middle
RTOL_BISECTION = 1e-3


# -- the loops, built independently with python-control --------------------------------------
def plant_io(plant, ids, orders, speed, w_F):
    """``(A, B, C, D)``: forces at the feet ``ids`` -> their measured signals of ``orders``."""
    n = plant.n
    M_inv = np.linalg.inv(plant.mass)
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-M_inv @ plant.stiffness_at(speed, w_F), -M_inv @ plant.damping(speed, w_F)]])
    forces = np.array([plant.actuator(i).force_vector for i in ids]).T
    B = np.vstack([np.zeros((n, len(ids))), M_inv @ forces])
    C, D = [], []
    for i, k in zip(ids, orders):
        s = plant.actuator(i).sensor_row
        C.append(np.concatenate([s, 0 * s]) if k == 0 else np.concatenate([0 * s, s]) if k == 1
                 else s @ A[n:])
        D.append(s @ M_inv @ forces if k == 2 else np.zeros(len(ids)))
    return A, B, np.array(C), np.array(D)


def loop_i(G, ctrls, i):
    """Controller ``i`` times the plant from force ``i`` to signal ``i`` with the others closed."""
    zero = control.ss([], [], [], [[0.0]], dt=G.dt)
    K = control.append(*[control.ss(c) if j != i else zero for j, c in enumerate(ctrls)])
    return control.ss(ctrls[i]) * control.feedback(G, K, sign=-1)[i, i]


def dense_grid(L, w_min, w_max):
    """4000 log points plus 81 around every pole python-control finds (as s = ln z / T)."""
    p = L.poles()
    if L.dt:
        p = np.log(p[np.abs(p) > 1e-12].astype(complex)) / L.dt
    p = p[p.imag > w_min]
    near = (p.imag[:, None] + np.maximum(abs(p.real), 1e-6 * p.imag)[:, None]
            * np.linspace(-8, 8, 81)).ravel()
    w = np.unique(np.concatenate([np.logspace(np.log10(w_min), np.log10(w_max), 4000), near]))
    return w[(w >= w_min) & (w <= w_max)]


def reference(L, w_min, w_max):
    """python-control's margins of ``L`` in the band ``[w_min, w_max]`` (the cancelled
    integrators of the other loops leave poles at ~1e-13 rad/s in its state-space model); for a
    sampled loop with the crossing of the real axis at Nyquist (``L(-1)`` is real: an end point
    the FRD search cannot bracket) and the limit at w = 0 added; crossings through a numerical
    zero of ``L`` (a Tustin zero at Nyquist: |L| < 1e-10 max |L|) left out."""
    w = dense_grid(L, w_min, w_max)
    frd = control.frd(L, w)
    gm, pm, sm, w_pc, w_gc, _ = control.stability_margins(frd, returnall=True)
    ends = [complex(L(-1.0))] if L.dt else [complex(L(1j * 1e3 * w_max))]
    if L.dt and ends[0].real < 0:
        gm, w_pc = np.append(gm, 1 / abs(ends[0])), np.append(w_pc, w_max)
    # w = 0: the limit of Re L (even in w) from w_min and w_min/2, where L(0) itself is 0/0
    # (the integrators of G_c meeting the zero of a derivative signal)
    at = [np.exp(1j * x * L.dt) if L.dt else 1j * x for x in (w_min, w_min / 2)]
    dc = ((4 * complex(L(at[1])) - complex(L(at[0]))) / 3).real
    if dc < -1e-6 * np.abs(frd.frdata).max():
        gm, w_pc = np.append(gm, -1 / dc), np.append(w_pc, 0.0)
    keep = 1 / gm > 1e-10 * np.abs(frd.frdata).max()
    sm = np.concatenate([sm, np.abs(1 + np.array(ends))])
    dm = control.disk_margins(L, w)[0]
    return gm[keep], w_pc[keep], pm, w_gc, 1 / sm.min(), dm


@pytest.fixture(scope="module", params=CASES, ids=[f"{c}@{s:g}Hz" for c, s in CASES])
def case(request):
    name, speed_hz = request.param
    machine = load_machine(name)
    speed = 2 * math.pi * speed_hz
    w_F = machine_poles(machine, speed).w_F
    ids = list(machine.controllers)
    orders = [c.order for c in machine.controllers.values()]
    return machine, speed, w_F, ids, plant_io(machine.plant, ids, orders, speed, w_F)


def check_against_python_control(margins, L, w_max):
    gm, w_pc, pm, w_gc, ms, dm = reference(L, margins.w_rad_s[0], w_max)
    mine_pc = np.array(margins.phase_crossovers).reshape(-1, 2)
    mine_gc = np.array(margins.gain_crossovers).reshape(-1, 2)
    np.testing.assert_allclose(np.sort(w_pc) / (2 * np.pi), mine_pc[:, 0], rtol=RTOL)
    np.testing.assert_allclose(gm[np.argsort(w_pc)], mine_pc[:, 1], rtol=RTOL)
    np.testing.assert_allclose(w_gc / (2 * np.pi), mine_gc[:, 0], rtol=RTOL)
    np.testing.assert_allclose(pm, mine_gc[:, 1], rtol=RTOL, atol=1e-6)
    above, below = gm[gm > 1], gm[gm < 1]
    assert margins.gain_margin == pytest.approx(above.min() if above.size else np.inf, rel=RTOL)
    assert margins.gain_margin_lower == pytest.approx(below.max() if below.size else 0.0,
                                                      rel=RTOL)
    if above.size:
        assert margins.phase_crossover_hz == pytest.approx(
            w_pc[gm == above.min()][0] / (2 * np.pi), rel=RTOL)
    k = np.argmin(np.abs(pm))
    assert margins.phase_margin_deg == pytest.approx(pm[k], rel=RTOL)
    assert margins.crossover_hz == pytest.approx(w_gc[k] / (2 * np.pi), rel=RTOL)
    assert margins.sensitivity_peak == pytest.approx(ms, rel=RTOL_PEAK)
    assert margins.disk_margin == pytest.approx(dm, rel=RTOL_PEAK)


def test_continuous_margins_equal_python_control(case):
    machine, speed, w_F, ids, (A, B, C, D) = case
    G = control.ss(A, B, C, D)
    ctrls = [control.tf(c.num, c.den) for c in machine.controllers.values()]
    frf = continuous_loop_frf(machine.plant, machine.controllers, speed, w_F)
    for i, foot in enumerate(ids):
        check_against_python_control(loop_margins(frf, foot), loop_i(G, ctrls, i), 1e5)


@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_sampled_margins_equal_python_control(case, rate_hz):
    machine, speed, w_F, ids, (A, B, C, D) = case
    T = 1.0 / rate_hz
    Phi, Gamma, _, _, _ = scipy.signal.cont2discrete((A, B, C, D), T, "zoh")
    m = len(ids)
    # y_k = C x_k + D u_{k-1}: the feed-through of the force held over the last interval
    G = (control.ss(Phi, Gamma, C, np.zeros((m, m)), dt=T)
         + control.ss(np.zeros((m, m)), np.eye(m), D, np.zeros((m, m)), dt=T))
    loop = machine_sampled_loop(machine, T)
    ctrls = [control.tf(tf.b, tf.a, dt=T) for tf in loop.controllers.values()]
    analysis = analyse_loop(sampled_loop_frf(loop, speed, w_F))
    for i, foot in enumerate(ids):
        check_against_python_control(analysis.loops[foot], loop_i(G, ctrls, i), math.pi / T)
    # (b) the all-loop factor from det(I + g L) = 0 is the eigenvalue bisection's
    rng = loop.stable_gain_range(speed, w_F)
    assert rng.stable_at_nominal and rng.lower == 0.0 == analysis.gain_margin_frf[0]
    assert analysis.gain_margin_frf[1] == pytest.approx(rng.upper, rel=RTOL_BISECTION)
    assert analysis.gain_margin_frf[1] < min(lm.gain_margin for lm in analysis.loops.values())


def scaled(ctrl: ContinuousController, g: float) -> ContinuousController:
    return ContinuousController(g * ctrl.num, ctrl.den, ctrl.feedback)


def test_continuous_all_loop_gain_margin_equals_eigenvalue_bisection():
    """I control on the foot displacements of the Werner 2021 machine (finite gain range in
    continuous time): the FRF factor against a bisection of the closed-loop eigenvalues."""
    machine = load_machine("foot_mount_case3")
    ctrls = {k: i_controller(5e5, "displacement") for k in machine.controllers}
    w_F = machine_poles(machine, 0.0).w_F
    lower, upper = gain_margin_frf(continuous_loop_frf(machine.plant, ctrls, 0.0, w_F))

    def stable(g):
        loop = ClosedLoop(machine.plant, {k: scaled(c, g) for k, c in ctrls.items()})
        return np.linalg.eigvals(loop.state_space(0.0, w_F)[0]).real.max() < 0
    assert lower == 0.0 and stable(1.0) and np.isfinite(upper)
    g_in, g_out = 1.0, upper * 1.01
    assert not stable(g_out)
    while g_out / g_in - 1 > 1e-9:
        g_in, g_out = ((math.sqrt(g_in * g_out), g_out) if stable(math.sqrt(g_in * g_out))
                       else (g_in, math.sqrt(g_in * g_out)))
    assert upper == pytest.approx(g_in, rel=1e-8)


# -- closed forms ---------------------------------------------------------------------------------
MASS, STIFF, DAMP, KI = 100.0, 4.0e4, 200.0, 1.0e4


def single_masses(n, stiffness, damping):
    """``n`` uncoupled masses, each with a force and a displacement sensor (and an unbalance,
    which the sampled loop's assembly expects; zero at standstill)."""
    eye = np.eye(n)
    acts = tuple(Actuator(f"A{i}", eye[i], eye[i]) for i in range(n))
    return LinearPlant("masses", tuple(f"z{i}" for i in range(n)), MASS * eye, stiffness * eye,
                       0 * eye, damping * eye, 0 * eye, 0 * eye, acts,
                       (Excitation("unbalance", "kg m", eye[0]),), (), 1.0)


def test_mass_spring_damper_under_integral_control_in_closed_form():
    """``L = K_I / (s (m s^2 + c s + k))``: phase crossover at ``sqrt(k/m)`` with
    ``GM = c k / (m K_I)``; the gain crossover solves ``w^2 (c^2 w^2 + (k - m w^2)^2) = K_I^2``,
    ``PM = 180 deg + arg L``. Two uncoupled copies: each loop the same, and all loops together
    lose stability at the same factor."""
    w_pc = math.sqrt(STIFF / MASS)
    gm = DAMP * STIFF / (MASS * KI)
    x = np.roots([MASS**2, DAMP**2 - 2 * STIFF * MASS, STIFF**2, -KI**2])   # cubic in w^2
    w_c = math.sqrt(x[np.isreal(x) & (x.real > 0)].real.min())
    pm = 180 + math.degrees(np.angle(KI / (1j * w_c * (STIFF - MASS * w_c**2 + 1j * DAMP * w_c))))
    assert 1 < gm < 10 and len(x[np.isreal(x) & (x.real > 0)]) == 1
    for n in (1, 2):
        plant = single_masses(n, STIFF, DAMP)
        ctrls = {a.id: i_controller(KI, "displacement") for a in plant.actuators}
        analysis = analyse_loop(continuous_loop_frf(plant, ctrls, 0.0, 1.0))
        for m in analysis.loops.values():
            assert m.gain_margin == pytest.approx(gm, rel=1e-10)
            assert m.phase_crossover_hz == pytest.approx(w_pc / (2 * math.pi), rel=1e-10)
            assert m.phase_margin_deg == pytest.approx(pm, rel=1e-10)
            assert m.crossover_hz == pytest.approx(w_c / (2 * math.pi), rel=1e-10)
        assert analysis.gain_margin_frf == pytest.approx((0.0, gm), rel=1e-10)


def test_sampled_free_mass_under_velocity_feedback_in_closed_form():
    """A free mass sampled with a zero-order hold: ``v_k+1 = v_k + T u_k / m``, so with
    ``u = -K_P v`` the loop is ``L(z) = k / (z - 1)``, ``k = K_P T / m``: on the unit circle
    ``L(-1) = -k/2`` (GM = 2/k at Nyquist), ``|L| = 1`` at ``wT = 2 asin(k/2)`` with
    ``arg L = -(90 deg + wT/2)``, and ``|S|`` grows to ``2/(2 - k)`` at Nyquist (k < 1); the
    closed-loop pole ``z = 1 - g k`` reaches -1 at ``g = 2/k``."""
    T, k = 1e-3, 0.5
    kp = k * MASS / T
    plant = single_masses(1, 0.0, 0.0)
    loop = SampledLoop(plant, {"A0": discretize_controller(p_controller(kp, "velocity"), T)},
                       {"A0": 0})
    analysis = analyse_loop(sampled_loop_frf(loop, 0.0, 1.0))
    m = analysis.loops["A0"]
    theta = 2 * math.asin(k / 2)
    assert m.gain_margin == pytest.approx(2 / k, rel=1e-12)
    assert m.phase_crossover_hz == pytest.approx(0.5 / T, rel=1e-12)
    assert m.phase_margin_deg == pytest.approx(90 - math.degrees(theta) / 2, rel=1e-10)
    assert m.crossover_hz == pytest.approx(theta / (2 * math.pi * T), rel=1e-10)
    assert m.sensitivity_peak == pytest.approx(2 / (2 - k), rel=1e-10)
    assert analysis.gain_margin_frf[1] == pytest.approx(2 / k, rel=1e-12)
    # the sampled loop's eigenvalues: z = -1 at g = 2/k (and the free position's z = 1 always)
    z = loop.poles(0.0, 1.0, gain=2 / k).z
    assert np.abs(z + 1).min() < 1e-9 and np.abs(z - 1).min() < 1e-9
