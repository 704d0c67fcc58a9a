"""The periodic steady state of the sampled loop, to start a run without a transient.

At constant speed ``Omega`` every signal of the lockstep loop is ``Re{X e^{j theta_k}}`` with
``theta_{k+1} = theta_k + Omega T``; with ``z = e^{j Omega T}`` the stepper's own matrices give
(DESIGN.md section 3, controller ``i`` with filter ``H_i(z)`` and ``d_i`` delay samples)::

    z X = Phi X + Gamma_u U + g                  (propagation, excitation phasor g)
    Y   = R_x X + R_u U / z + r                  (measurement with u_{k-1} = U / z)
    U_i = -H_i(z) z^-d_i Y_fb(i)                 (the digital controllers; 0 when open)

one complex linear solve of size ``2n + m``. :func:`start_in_steady_state` sets the plant state,
``u_{-1}``, and each controller: its extra delay line is filled by stepping it through the past
``delay_samples`` signals, then its filter state (direct form II transposed) is set from the past
input and output phasors, so the loop starts on its periodic solution. With the loops open this
is the continuous FRF exactly (the ZOH of a sinusoid is exact). Force and rate limits are not
part of it (a linear steady state).

While the speed changes at ``t = 0`` the result is the quasi-steady state at ``Omega(0)``.
:class:`rotor_avc.analysis.sampled_loop.SampledLoop` assembles the same sampled loop
independently (from ``discretize_plant`` and the filters' realisations); the tests hold the two
against each other.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .stepper import PlantStepper


@dataclass
class SteadyState:
    """Complex phasors at ``t_0``: plant state ``X`` (2n), forces ``U`` (m, actuator order),
    measurements ``Y`` (layout order); physical value ``Re{phasor e^{j theta_0}}``."""

    speed_rad_s: float
    angle_rad: float
    X: np.ndarray
    U: np.ndarray
    Y: np.ndarray


def _filter_response(ctrl, z: complex) -> complex:
    """``H(z) z^-d`` of a controller's filter (``b``, ``a`` in powers of ``z^-1``)."""
    zi = 1.0 / z
    b, a = np.asarray(ctrl.filter.b), np.asarray(ctrl.filter.a)
    return np.polyval(b[::-1], zi) / np.polyval(a[::-1], zi) * zi ** ctrl.delay_samples


def periodic_steady_state(stepper: PlantStepper, controllers: dict) -> SteadyState:
    """Steady-state phasors of the sampled loop at the speed of ``t = 0``."""
    speed, accel, angle = stepper.profile.sample(np.array([0.0, 0.5 * stepper.T]))
    if speed[0] <= 0:
        raise ModelError("a steady state needs a rotating shaft at t = 0 (speed > 0); "
                         "start at rest instead")
    tab, lay = stepper.table, stepper.table.layout
    S, R = tab.propagator(float(speed[1])), tab.measurement(float(speed[0]))
    # a real column pair [c, s] acting on w contributes Re{(col_c - j col_s) w}
    g = S[:, lay.w][:, 0::2] - 1j * S[:, lay.w][:, 1::2]
    r = R[:, lay.w][:, 0::2] - 1j * R[:, lay.w][:, 1::2]
    g = g @ stepper.basis_amplitudes(speed[1], accel[1])
    r = r @ stepper.basis_amplitudes(speed[0], accel[0])
    z = np.exp(1j * speed[0] * stepper.T)
    N, m = lay.x.stop, stepper.n_inputs
    Phi, Gu = S[:, lay.x], S[:, lay.u]
    Rx, Ru = R[:, lay.x], R[:, lay.u]
    K = np.zeros((m, R.shape[0]), complex)       # U = -K Y
    ids = [a.id for a in stepper.plant.actuators]
    for act_id, ctrl in controllers.items():
        K[ids.index(act_id), stepper.layout.feedback_index(act_id, ctrl.feedback)] = \
            _filter_response(ctrl, z)
    lhs = np.zeros((N + m, N + m), complex)
    lhs[:N, :N] = z * np.eye(N) - Phi
    lhs[:N, N:] = -Gu
    lhs[N:, :N] = K @ Rx
    lhs[N:, N:] = np.eye(m) + K @ Ru / z
    rhs = np.concatenate([g, -K @ r])
    sol = np.linalg.solve(lhs, rhs)
    X, U = sol[:N], sol[N:]
    Y = Rx @ X + Ru @ U / z + r
    return SteadyState(float(speed[0]), float(angle[0]), X, U, Y)


def start_in_steady_state(stepper: PlantStepper, controllers: dict) -> np.ndarray:
    """Reset the stepper and the controllers onto the periodic solution; return ``y_0``."""
    ss = periodic_steady_state(stepper, controllers)
    rot = np.exp(1j * ss.angle_rad)
    z = np.exp(1j * ss.speed_rad_s * stepper.T)
    y0 = stepper.reset((ss.X * rot).real, (ss.U * rot / z).real)
    ids = [a.id for a in stepper.plant.actuators]
    for act_id, ctrl in controllers.items():
        ctrl.reset()
        Y = ss.Y[stepper.layout.feedback_index(act_id, ctrl.feedback)]
        d = ctrl.delay_samples
        for j in range(d, 0, -1):                    # fill the delay line with y_-d .. y_-1
            ctrl.step(complex(Y * rot * z ** -j).real)
        filt = ctrl.filter
        W = Y * z ** -d
        V = -ss.U[ids.index(act_id)]                 # filter output; force = -output
        n = filt.n
        state = [sum((filt.b[j] * W - filt.a[j] * V) * z ** (i - j) for j in range(i + 1, n + 1))
                 for i in range(n)]
        filt.set_state([complex(s * rot).real for s in state])
        ctrl.limits.reset(complex(V * rot / z).real)
        ctrl.last_force_n = complex(-V * rot / z).real
    return y0.copy()
