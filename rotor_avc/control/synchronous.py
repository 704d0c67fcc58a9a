"""Synchronous (1x) force generator locked to the rotor angle: Sci. Rep. 2023's quantified force and
phase as a block, for the in-process loop and a controller node.

The feed-forward of :mod:`rotor_avc.analysis.active_bearing_ff` gives, per speed, the complex
actuator forces per unit unbalance ``T_i(Omega)`` [N per kg m]; the wanted force is
``f_i(t) = Re{T_i(Omega) u e^{j theta(t)}}`` with the shaft angle ``theta`` and the unbalance
``u = m_o e e^{j phi}`` [kg m] (configured, or later an RLS estimate, Zhou & Shi 2001). The block looks
``T`` up in a table over speed (linear interpolation of real and imaginary parts) and plays it
against the measured shaft angle; outside the table it commands zero force and says so. The
table is interpolated as ``T / Omega^2`` (the unbalance force grows with ``Omega^2``, so this
part varies slowly away from resonances), linearly in its real and imaginary parts.

Sampling contract (DESIGN.md 3): the force ``u_k`` computed at ``t_k`` is held over
``[t_k+d, t_k+d+1)``, where ``d = delay_samples`` is a known transport delay downstream of the
block (0 in the in-process loop), which the block compensates by a phase advance rather than
adds. A held sinusoid reaches the plant with
the fundamental ``sinc(Omega T / 2) e^{-j Omega (T/2 + d T)}`` times the samples' phasor, so the
block compensates exactly: ``u_k = Re{T u e^{j (theta_k + Omega (T/2 + d T))}} / sinc(Omega T / 2)``
(``sample_period_s=None``: continuous use, no compensation).
"""
from __future__ import annotations

import math

import numpy as np

from ..blocks import SnapshotState
from ..errors import ModelError


class SynchronousForceGenerator(SnapshotState):
    """``reset()`` / ``step(shaft_angle_rad, speed_rad_s) -> forces [N]`` (module docstring);
    a :class:`rotor_avc.blocks.Synchronous` block (state: the last force, whether in range)."""

    STATE = ("force_n", "in_range")

    def __init__(self, speed_table_rad_s, forces_per_unit, unbalance_kg_m: complex,
                 actuator_ids, *, sample_period_s: float | None = None, delay_samples: int = 0):
        speeds = np.asarray(speed_table_rad_s, dtype=float)
        table = np.asarray(forces_per_unit, dtype=complex)
        self.actuator_ids = tuple(actuator_ids)
        if speeds.ndim != 1 or speeds.size < 1 or np.any(~np.isfinite(speeds)) \
                or speeds[0] <= 0 or np.any(np.diff(speeds) <= 0):
            raise ModelError("the force table needs finite speeds > 0 in strictly ascending order")
        if table.shape != (speeds.size, len(self.actuator_ids)) or not np.all(np.isfinite(table)):
            raise ModelError(f"the force table must be finite with shape (speeds, actuators) = "
                             f"({speeds.size}, {len(self.actuator_ids)}), got {table.shape}")
        if sample_period_s is not None and not (math.isfinite(sample_period_s) and sample_period_s > 0):
            raise ModelError(f"sample_period_s must be > 0 or None (got {sample_period_s})")
        if isinstance(delay_samples, bool) or not isinstance(delay_samples, int) or delay_samples < 0:
            raise ModelError(f"delay_samples must be an integer >= 0 (got {delay_samples!r})")
        if sample_period_s is not None and speeds[-1] >= math.pi / sample_period_s:
            raise ModelError(f"the force table reaches {speeds[-1] / (2 * math.pi):g} Hz, at or "
                             f"above the Nyquist frequency {0.5 / sample_period_s:g} Hz of the "
                             "sample rate -- raise the sample rate or shorten the table")
        self.speed_table_rad_s = speeds
        self.forces_per_unit = table
        self._per_speed2 = table / speeds[:, None] ** 2
        self.unbalance_kg_m = complex(unbalance_kg_m)
        if not np.isfinite(self.unbalance_kg_m):
            raise ModelError(f"the unbalance must be finite (got {unbalance_kg_m})")
        self.sample_period_s = sample_period_s
        self.delay_samples = delay_samples
        self.reset()

    def reset(self) -> None:
        """Back to the initial state: no force commanded yet."""
        self.force_n = np.zeros(len(self.actuator_ids))
        self.in_range = True

    def phasors(self, speed_rad_s: float) -> np.ndarray:
        """Force phasors ``T(Omega) u`` [N] at one speed (NaN outside the table)."""
        sp = self.speed_table_rad_s
        if not sp[0] <= speed_rad_s <= sp[-1]:
            return np.full(len(self.actuator_ids), np.nan + 0j)
        k = min(int(np.searchsorted(sp, speed_rad_s, side="right")), sp.size - 1)
        t = self._per_speed2
        if k == 0:
            row = t[0]
        else:
            w = (speed_rad_s - sp[k - 1]) / (sp[k] - sp[k - 1])
            row = (1.0 - w) * t[k - 1] + w * t[k]
        return row * speed_rad_s**2 * self.unbalance_kg_m

    def step(self, shaft_angle_rad: float, speed_rad_s: float) -> np.ndarray:
        """Forces [N] (actuator order) to hold from this sample on."""
        phasor = self.phasors(speed_rad_s)
        self.in_range = bool(np.all(np.isfinite(phasor)))
        if not self.in_range:
            self.force_n = np.zeros(len(self.actuator_ids))
            return self.force_n.copy()
        angle = shaft_angle_rad
        gain = 1.0
        if self.sample_period_s is not None:
            half = 0.5 * speed_rad_s * self.sample_period_s
            angle += speed_rad_s * self.sample_period_s * (0.5 + self.delay_samples)
            gain = half / math.sin(half) if half > 0 else 1.0     # 1 / sinc, half < pi/2
        self.force_n = gain * (phasor * np.exp(1j * angle)).real
        return self.force_n.copy()
