"""Closed-loop transfer functions from one actuator's force to the measured quantities, at a
fixed rotor speed: the model of a broadband FRF measurement (a test force, rotor_avc.sim.broadband).

A force ``d`` at actuator ``i`` (vector ``P_i``) enters the closed loop beside the controllers,
which keep acting on their own feedback signals. Responses per unit force:

* continuous (Werner 2021 eqs. 41-42 with ``P_i d`` in place of the unbalance phasor)::

      q(w) = Z(j w)^-1 P_i,     quantity = (j w)^order row . q,     f_c = -H_c(j w) s_c . q

  where ``Z`` is :meth:`rotor_avc.closed_loop.loop.ClosedLoop.dynamic_stiffness` and
  ``f_c`` the force a controller answers with (zero at actuators without one);
* sampled (DESIGN.md section 3; the plant exactly ZOH-discretised by
  :func:`rotor_avc.models.discretize.discretize_plant`, ``z = e^{j w T}``): the applied actuator
  forces ``a`` (all actuators) give ``X = (z I - Phi)^-1 Gamma_u a`` and a quantity
  ``C X + D a / z`` (``D``: the acceleration's feed-through of the forces held over the previous
  interval); each controller answers ``u_c = -G_d,c(z) z^-d_c y_c``; with ``a = S u + e_i d``::

      a = (I + S K P_fb)^-1 e_i,   quantity = P(z) a,   u = -K P_fb a

  the sequence-to-sequence transfer an H1/H2 estimate of a lockstep run measures.

The damping frequency ``w_F`` is an explicit argument: a scalar (the value a fixed-speed run
froze, ``w_F = max(Omega, floor)`` for ``damping_at: speed`` -- viscous-equivalent damping, not
the hysteretic model), or one value per frequency (``w_F = w``: the hysteretic model, continuous
only). Quantity names: ``plant.outputs`` names, foot signals ``foot_<id>_{d,v,a}<axis>`` (the
sensor row of actuator ``id``) and controller forces ``actuator_<id>_f<axis>``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..control.spec import FEEDBACK_ORDER
from ..errors import ModelError
from ..models.discretize import discretize_plant
from ..models.plant import LinearPlant
from ..closed_loop.loop import ClosedLoop

_FOOT = {"d": (0, "m"), "v": (1, "m/s"), "a": (2, "m/s^2")}


@dataclass
class TransferFrf:
    """Responses per unit input force (SI unit / N) over ``freq_hz`` at one speed."""

    freq_hz: np.ndarray
    responses: dict[str, np.ndarray]
    units: dict[str, str]
    input: str
    speed_rad_s: float
    w_F: np.ndarray
    model: str                  # "continuous" or "sampled"


def quantity(plant: LinearPlant, name: str):
    """``("row", row, order, unit)`` of an output or foot signal, ``("force", id, None, "N")`` of
    a controller force; ModelError naming the known quantities otherwise."""
    for out in plant.outputs:
        if out.name == name:
            return "row", out.row, out.order, out.unit
    for act in plant.actuators:
        for letter, (order, unit) in _FOOT.items():
            if name == f"foot_{act.id}_{letter}{act.axis}":
                return "row", act.sensor_row, order, unit
    for point, axis in plant.force_points:
        if name == f"actuator_{point}_f{axis}":
            return "force", point, None, "N"
    known = [o.name for o in plant.outputs] + ["foot_<id>_{d,v,a}<axis>", "actuator_<id>_f<axis>"]
    raise ModelError(f"{plant.name}: no quantity {name!r}; known: " + ", ".join(known))


def _inputs(plant, freq_hz, input_id, outputs):
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if f.ndim != 1 or f.size == 0 or not np.all(np.isfinite(f)) or np.any(f < 0):
        raise ModelError("transfer frequencies must be a non-empty 1-D list of finite values >= 0")
    plant.actuator(input_id)
    names = list(outputs) if outputs is not None else [o.name for o in plant.outputs]
    return f, names, {n: quantity(plant, n) for n in names}


def _w_F(plant, speed_rad_s, w_F, shape):
    value = plant.forced_damping_frequency(speed_rad_s) if w_F is None else w_F
    return np.broadcast_to(np.asarray(value, dtype=float), shape)


def transfer_frf(loop: ClosedLoop, speed_rad_s: float, freq_hz, input_id: str, outputs=None,
                 w_F=None) -> TransferFrf:
    """Continuous closed-loop responses to a unit force at ``input_id`` (module docstring).
    ``w_F`` defaults to ``max(Omega, floor)``, frozen over the frequencies."""
    plant = loop.plant
    f, names, spec = _inputs(plant, freq_hz, input_id, outputs)
    wf = _w_F(plant, speed_rad_s, w_F, f.shape)
    s = 2j * np.pi * f
    Z = loop.dynamic_stiffness(s, float(speed_rad_s), wf)
    Q = np.linalg.solve(Z, np.broadcast_to(plant.actuator(input_id).force_vector,
                                           f.shape + (plant.n,))[..., None])[..., 0]
    forces = loop.force_rows(s)
    out, units = {}, {}
    for name in names:
        kind, ref, order, unit = spec[name]
        if kind == "row":
            out[name] = (Q @ ref) * s ** order
        else:                          # zero at a point without a controller (a passive element)
            out[name] = np.einsum("fn,fn->f", forces.get(ref, np.zeros_like(Q)), Q)
        units[name] = f"{unit}/N"
    return TransferFrf(f, out, units, input_id, float(speed_rad_s), wf.copy(), "continuous")


def sampled_transfer_frf(loop, speed_rad_s: float, freq_hz, input_id: str, outputs=None,
                         w_F=None) -> TransferFrf:
    """Sampled-loop responses (sequence to sequence) to a unit force sequence at ``input_id``
    for a :class:`rotor_avc.analysis.sampled_loop.SampledLoop` (module docstring); ``w_F`` a
    scalar, default ``max(Omega, floor)``."""
    plant = loop.plant
    T = loop.sample_period_s
    f, names, spec = _inputs(plant, freq_hz, input_id, outputs)
    wf = float(np.asarray(plant.forced_damping_frequency(speed_rad_s) if w_F is None else w_F))
    if np.any(f >= 0.5 / T):
        raise ModelError("transfer frequencies must lie below the Nyquist frequency "
                         f"{0.5 / T:g} Hz")
    dp = discretize_plant(plant, float(speed_rad_s), wf, T)
    n, N = plant.n, 2 * plant.n
    ids = [a.id for a in plant.actuators]
    P = np.array([a.force_vector for a in plant.actuators]).reshape(len(ids), n).T     # (n, m)
    z = np.exp(2j * np.pi * f * T)
    Xa = np.linalg.solve(z[:, None, None] * np.eye(N) - dp.Phi, dp.Gamma_u)          # (F, N, m)

    def measured(row, order):                    # (F, m): quantity per unit applied force
        C = np.zeros(N)
        if order == 0:
            C[:n] = row
        elif order == 1:
            C[n:] = row
        else:
            C = row @ dp.accel_state
        D = row @ dp.accel_force @ P if order == 2 else np.zeros(len(ids))
        return C @ Xa + D / z[:, None]

    ctrl = list(loop.controllers)
    S = np.zeros((len(ids), len(ctrl)))
    P_fb = np.zeros((f.size, len(ctrl), len(ids)), complex)
    K = np.zeros((f.size, len(ctrl)), complex)
    for c, act_id in enumerate(ctrl):
        tf = loop.controllers[act_id]
        S[ids.index(act_id), c] = 1.0
        P_fb[:, c] = measured(plant.actuator(act_id).sensor_row, FEEDBACK_ORDER[tf.feedback])
        K[:, c] = tf(z) * z ** -loop.delay_samples.get(act_id, 0)
    L = np.eye(len(ids)) + S @ (K[:, :, None] * P_fb)
    e_in = np.zeros(len(ids))
    e_in[ids.index(input_id)] = 1.0
    a = np.linalg.solve(L, np.broadcast_to(e_in, (f.size, len(ids)))[..., None])[..., 0]
    u = -K * np.einsum("fcm,fm->fc", P_fb, a)
    out, units = {}, {}
    for name in names:
        kind, ref, order, unit = spec[name]
        if kind == "row":
            out[name] = np.einsum("fm,fm->f", measured(ref, order), a)
        else:
            out[name] = u[:, ctrl.index(ref)] if ref in ctrl else np.zeros(f.size, complex)
        units[name] = f"{unit}/N"
    return TransferFrf(f, out, units, input_id, float(speed_rad_s), np.full(f.shape, wf),
                       "sampled")
