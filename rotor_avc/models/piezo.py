"""A piezo stack actuator with its real limits: stroke, blocked force, voltage and bandwidth.

Sci. Rep. 2023 blames the loss of control at high speed on the limited piezo stroke but states no
actuator data. A multilayer stack of stiffness ``k_p`` driven by voltage ``V`` develops the force
``k_p delta_free(V)`` across itself, where the free (unloaded) elongation is linear in the
voltage: ``delta_free = delta_0 V / V_max`` with the nominal stroke ``delta_0`` and the blocked
force ``F_b = k_p delta_0`` at ``V_max``. The model's actuator force ``f_ac`` (the paper's force
vector, eqs. 8-9) is this generated force, so one sinusoidal force amplitude ``|F|`` needs

* the free-stroke amplitude ``|F| / k_p`` and the voltage amplitude ``|F| V_max / (F_b |G(j Omega)|)``;
* within the drive range ``[V_min, V_max]``: a sinusoid about the mid voltage has at most the
  amplitude ``(V_max - V_min) / 2``, so a unipolar drive (``V_min = 0``) uses half the stroke;
* through the first-order lag ``G(j Omega) = 1 / (1 + j Omega / omega_b)`` of stack and amplifier
  (bandwidth ``omega_b``), whose phase the command compensates but whose gain it cannot exceed.

Hence the force limit ``F_lim(Omega) = F_b (V_max - V_min) / (2 V_max) |G(j Omega)|``. When a
feed-forward asks for more, :meth:`PiezoStack.saturation_scale` scales all forces together by
``alpha = min(1, min_i F_lim / |F_i|)``, which keeps the cancelling force pattern: the motion the
forces were meant to cancel becomes ``(1 - alpha)`` times its uncontrolled value.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError


@dataclass(frozen=True)
class PiezoStack:
    """One stack (SI units); see the module docstring."""

    free_stroke_m: float
    blocked_force_n: float
    bandwidth_hz: float
    max_voltage_v: float
    min_voltage_v: float = 0.0

    def __post_init__(self):
        for name in ("free_stroke_m", "blocked_force_n", "bandwidth_hz", "max_voltage_v"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ModelError(f"piezo {name} must be finite and > 0 (got {value})")
        if not np.isfinite(self.min_voltage_v) or self.min_voltage_v >= self.max_voltage_v:
            raise ModelError(f"piezo min_voltage_v ({self.min_voltage_v}) must be below "
                             f"max_voltage_v ({self.max_voltage_v})")

    @property
    def stiffness_n_per_m(self) -> float:
        """``k_p = F_b / delta_0``."""
        return self.blocked_force_n / self.free_stroke_m

    @property
    def amplitude_fraction(self) -> float:
        """Largest sinusoidal voltage amplitude as a fraction of ``V_max``."""
        return (self.max_voltage_v - self.min_voltage_v) / (2 * self.max_voltage_v)

    def lag(self, speed_rad_s) -> np.ndarray:
        """``G(j Omega) = 1 / (1 + j Omega / omega_b)``."""
        return 1.0 / (1.0 + 1j * np.asarray(speed_rad_s, float) / (2 * np.pi * self.bandwidth_hz))

    def force_limit_n(self, speed_rad_s) -> np.ndarray:
        """Largest force amplitude at ``Omega`` [N]: ``F_b * amplitude_fraction * |G|``."""
        return self.blocked_force_n * self.amplitude_fraction * np.abs(self.lag(speed_rad_s))

    def free_stroke_amplitude_m(self, force_n) -> np.ndarray:
        """Free-stroke amplitude ``|F| / k_p`` a force amplitude needs [m]."""
        return np.abs(force_n) / self.stiffness_n_per_m

    def voltage_phasor_v(self, force_n, speed_rad_s) -> np.ndarray:
        """Voltage phasor (about the mid voltage) producing the force phasor ``F`` at ``Omega``,
        lag compensated: ``F V_max / (F_b G(j Omega))``; ``force_n`` shape (N, m), speed (N,)."""
        g = self.lag(speed_rad_s)
        return np.asarray(force_n) * self.max_voltage_v / (self.blocked_force_n * g[..., None])

    def saturation_scale(self, force_n, speed_rad_s) -> np.ndarray:
        """``alpha = min(1, min_i F_lim / |F_i|)`` per speed; ``force_n`` shape (N, m)."""
        peak = np.max(np.abs(np.asarray(force_n)), axis=-1)
        limit = self.force_limit_n(speed_rad_s)
        with np.errstate(divide="ignore"):
            return np.minimum(1.0, np.where(peak > 0, limit / peak, np.inf))
