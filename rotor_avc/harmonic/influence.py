"""The influence (secondary-path) matrix of harmonic control and its schedule over speed.

``G_h(Omega)[i, j]`` is the phasor of sensor ``i``'s samples per unit phasor of the force
samples commanded at actuator ``j`` at the ``h``-th harmonic of the shaft speed: with
``u_k = Re{U e^{j h theta_k}}`` the samples settle to ``y_k = Re{G_h U e^{j h theta_k}}``. From a
model it is the sampled-loop transfer (DESIGN.md section 3, zero-order hold and the feedback
controllers the run has included: :func:`rotor_avc.analysis.transfer.sampled_transfer_frf`) at
``h Omega``. The schedule tabulates it on a speed grid with a constant relative step and
interpolates real and imaginary parts linearly (speed scheduling during a run-up).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..closed_loop.speed_table import SpeedTable
from ..errors import ModelError


@dataclass(frozen=True, eq=False)
class InfluenceSchedule:
    """``matrices[s, h]`` (M, N) at ``speeds_rad_s[s]`` for ``harmonics[h]``."""

    speeds_rad_s: np.ndarray
    harmonics: tuple[int, ...]
    matrices: np.ndarray
    sensors: tuple[str, ...]
    actuators: tuple[str, ...]
    #: optional 1x response of the sensors per unit amplitude of the plant's synchronous
    #: excitations (unbalance), ``(S, M, n_excitations)``: the disturbance model
    disturbance: np.ndarray | None = None
    excitations: tuple[str, ...] = ()

    def __post_init__(self):
        sp = self.speeds_rad_s
        if sp.ndim != 1 or sp.size < 1 or np.any(~np.isfinite(sp)) or sp[0] <= 0 \
                or np.any(np.diff(sp) <= 0):
            raise ModelError("the influence schedule needs speeds > 0 in ascending order")

        shape = (sp.size, len(self.harmonics), len(self.sensors), len(self.actuators))
        if self.matrices.shape != shape or not np.all(np.isfinite(self.matrices)):
            raise ModelError(f"influence matrices must be finite with shape {shape} "
                             f"(got {self.matrices.shape})")
        if self.disturbance is not None and (
                self.disturbance.shape != (sp.size, len(self.sensors), len(self.excitations))
                or not np.all(np.isfinite(self.disturbance))):
            raise ModelError("the disturbance model must be finite with shape (speeds, sensors, "
                             "excitations)")
        object.__setattr__(self, "_matrices", SpeedTable(sp, self.matrices, clamp=True))
        object.__setattr__(self, "_disturbance", None if self.disturbance is None
                           else SpeedTable(sp, self.disturbance, clamp=True))

    def covers(self, speed_rad_s: float) -> bool:
        return self._matrices.covers(speed_rad_s)

    def at(self, speed_rad_s: float) -> np.ndarray:
        """``(H, M, N)`` interpolated at one speed (clamped to the table's ends)."""
        return self._matrices.at(speed_rad_s)

    def disturbance_at(self, speed_rad_s: float) -> np.ndarray:
        """``(M, n_excitations)`` of the disturbance model at one speed."""
        if self._disturbance is None:
            raise ModelError("this influence schedule has no disturbance model")
        return self._disturbance.at(speed_rad_s)

    def perturbed(self, phase_error_deg: float = 0.0, magnitude_factor: float = 1.0
                  ) -> "InfluenceSchedule":
        """The schedule times ``magnitude_factor e^{j phase_error}`` (a deliberately wrong
        estimate, for robustness studies)."""
        if not (np.isfinite(magnitude_factor) and magnitude_factor > 0):
            raise ModelError(f"magnitude_factor must be > 0 (got {magnitude_factor})")
        factor = magnitude_factor * np.exp(1j * np.deg2rad(phase_error_deg))
        return InfluenceSchedule(self.speeds_rad_s, self.harmonics, self.matrices * factor,
                                 self.sensors, self.actuators, self.disturbance, self.excitations)


def schedule_speeds(start_rad_s: float, stop_rad_s: float, rel_step: float) -> np.ndarray:
    """Speeds from ``start`` to ``stop`` with a constant relative step (both ends included)."""
    if not (0 < start_rad_s <= stop_rad_s and 0 < rel_step < 1):
        raise ModelError("schedule speeds need 0 < start <= stop and 0 < rel_step < 1")
    n = max(int(np.ceil(np.log(stop_rad_s / start_rad_s) / np.log1p(rel_step))), 1)
    return np.geomspace(start_rad_s, stop_rad_s, n + 1) if stop_rad_s > start_rad_s \
        else np.array([start_rad_s])


def model_schedule(loop, sensors, actuators, harmonics, speeds_rad_s, w_F=None,
                   disturbance: bool = False) -> InfluenceSchedule:
    """The influence schedule of a :class:`rotor_avc.analysis.sampled_loop.SampledLoop` (the
    plant with the run's feedback controllers); ``w_F``: ``None`` for ``max(Omega, floor)`` or
    a frozen damping frequency (rad/s); ``disturbance``: add the sensors' sampled-loop 1x
    response per unit excitation (sensors must then be plant outputs)."""
    from ..analysis.transfer import sampled_transfer_frf
    speeds = np.asarray(speeds_rad_s, dtype=float)
    nyq = np.pi / loop.sample_period_s
    if speeds.size and max(harmonics) * speeds.max() >= nyq:
        raise ModelError(f"harmonic {max(harmonics)} of {speeds.max() / (2 * np.pi):g} Hz is at "
                         f"or above the Nyquist frequency {nyq / (2 * np.pi):g} Hz -- raise the "
                         "sample rate or drop that harmonic")
    outputs = [o.name for o in loop.plant.outputs]
    missing = [name for name in sensors if name not in outputs]
    if disturbance and missing:                   # checked before any response is computed
        raise ModelError(f"sensors {missing} have no unbalance response in the model; adapting "
                         "in the excitations needs plant outputs (" + ", ".join(outputs) + ")")
    out = np.zeros((speeds.size, len(harmonics), len(sensors), len(actuators)), complex)
    for s, speed in enumerate(speeds):
        freqs = [h * speed / (2 * np.pi) for h in harmonics]
        for j, act in enumerate(actuators):
            frf = sampled_transfer_frf(loop, speed, freqs, act, list(sensors), w_F)
            for i, name in enumerate(sensors):
                out[s, :, i, j] = frf.responses[name]
    if not disturbance:
        return InfluenceSchedule(speeds, tuple(harmonics), out, tuple(sensors), tuple(actuators))
    excs = tuple(e.name for e in loop.plant.excitations)
    wf = None if w_F is None else np.full(speeds.shape, w_F)
    frf = loop.unbalance_frf(speeds, w_F=wf)
    dist = np.stack([np.stack([frf.responses[f"{name}_{e}"] for e in excs], axis=-1)
                     for name in sensors], axis=1)
    return InfluenceSchedule(speeds, tuple(harmonics), out, tuple(sensors), tuple(actuators),
                             dist, excs)
