"""Closed-loop synchronous (unbalance) response over speed (Werner 2021 eqs. 41-42, A2-A4).

At each rotor speed ``Omega`` the excitation phasor ``F(Omega)`` drives the closed loop at
``s = j Omega`` with the damping of forced response, ``w_F = max(Omega, floor)`` (DESIGN.md 2)::

    q(Omega) = Z(j Omega)^-1 F(Omega)            (compact form of eq. 41/42)
    output   = (j Omega)^order  row . q           (A2, A3)
    force_i  = -H_i(j Omega) s_i^T q              (A4, eqs. 153-156)

Where the dynamic stiffness is a polynomial in the speed, one modal decomposition serves every
speed (:mod:`rotor_avc.closed_loop.modal_frf`); otherwise all speeds are solved in one batched
LAPACK call.
Response names are ``<output>_<excitation>``, e.g. ``bearing_D_vz_static``, and for forces
``actuator_<id>_f<axis>_<excitation>``; values are per unit excitation amplitude (per kg m for
static, per kg m^2 for moment unbalance).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..resources import COMPLEX_BYTES, check_memory, chunks
from .loop import ClosedLoop
from .modal_frf import solve_over_speed


@dataclass
class SpeedFrf:
    """Complex responses over rotor speed (rad/s), keyed by response name."""

    speed_rad_s: np.ndarray
    responses: dict[str, np.ndarray]
    units: dict[str, str]
    #: (quantity, excitation) of every response key, e.g. ("bearing_D_vz", "static")
    parts: dict[str, tuple[str, str]]

    @property
    def speed_hz(self) -> np.ndarray:
        return self.speed_rad_s / (2 * np.pi)

    def add(self, quantity: str, excitation: str, values: np.ndarray, unit: str) -> None:
        key = f"{quantity}_{excitation}"
        self.responses[key] = values
        self.units[key] = unit
        self.parts[key] = (quantity, excitation)

    def db(self, name: str) -> np.ndarray:
        """Magnitude in dB re 1 SI unit (eqs. 52-54); zero gives -inf."""
        with np.errstate(divide="ignore"):
            return 20 * np.log10(np.abs(self.responses[name]))


def unbalance_frf(loop: ClosedLoop, speed_rad_s, excitations=None, w_F=None,
                  accel_rad_s2=0.0) -> SpeedFrf:
    """Synchronous responses of every output and actuator force to each excitation.

    ``accel_rad_s2`` (scalar or per speed) adds the tangential ``-j Omega'`` part of the phasor
    of an accelerating rotor (quasi-steady 1x influence coefficients during a run-up).
    The size of the result is checked first (rotor_avc.resources); the speeds are evaluated in
    chunks, so the batched solve's matrices stay a bounded size."""
    plant = loop.plant
    speeds = np.atleast_1d(np.asarray(speed_rad_s, dtype=float))
    if speeds.ndim != 1 or speeds.size == 0 or np.any(~np.isfinite(speeds)) or np.any(speeds <= 0):
        raise ModelError("FRF speeds must be a non-empty list of positive, finite speeds")
    excs = plant.excitations if excitations is None else [plant.excitation(e) for e in excitations]
    n, m = len(plant.coords), len(excs)
    n_responses = (len(plant.outputs) + len(plant.force_points)) * m
    check_memory(speeds.size * n_responses * COMPLEX_BYTES, f"an FRF over {speeds.size} speeds",
                 "use fewer speeds")
    w_F = plant.forced_damping_frequency(speeds) if w_F is None else np.broadcast_to(w_F, speeds.shape)
    w_F = np.asarray(w_F, dtype=float)
    accel = np.broadcast_to(np.asarray(accel_rad_s2, dtype=float), speeds.shape)
    per_speed = COMPLEX_BYTES * (2 * n * n + 4 * n * m + 2 * n_responses)
    blocks = [_frf_block(loop, excs, speeds[a:b], w_F[a:b], accel[a:b])
              for a, b in chunks(speeds.size, per_speed)]
    if len(blocks) == 1:
        return blocks[0]
    result = SpeedFrf(speeds, {}, {}, {})
    for key, (quantity, excitation) in blocks[0].parts.items():
        result.add(quantity, excitation, np.concatenate([b.responses[key] for b in blocks]),
                   blocks[0].units[key])
    return result


def _frf_block(loop: ClosedLoop, excs, speeds, w_F, accel) -> SpeedFrf:
    """:func:`unbalance_frf` at one chunk of speeds."""
    plant = loop.plant
    s = 1j * speeds
    F = np.stack([e.phasor(speeds, accel) for e in excs], axis=-1)   # (N, n, m)
    Q = solve_over_speed(loop, speeds, w_F, F)   # (N, n, m)
    names, rows, orders = plant.output_rows()
    derivative = np.stack([np.ones_like(s), s, s * s], axis=-1)[:, orders]        # (N, k)
    N, n, m = Q.shape
    out_q = (Q.transpose(0, 2, 1).reshape(N * m, n) @ rows.T).reshape(N, m, -1)    # (N, m, k)
    out_q *= derivative[:, None, :]
    result = SpeedFrf(speeds, {}, {}, {})
    for k, out in enumerate(plant.outputs):
        for j, e in enumerate(excs):
            result.add(out.name, e.name, out_q[:, j, k], f"{out.unit}/({e.unit})")
    force_rows = loop.force_rows(s)
    for act_id, axis in plant.force_points:
        row = force_rows.get(act_id)
        for j, e in enumerate(excs):
            value = (np.einsum("Nn,Nn->N", row, Q[:, :, j]) if row is not None
                     else np.zeros(speeds.shape, complex))
            result.add(f"actuator_{act_id}_f{axis}", e.name, value, f"N/({e.unit})")
    return result
