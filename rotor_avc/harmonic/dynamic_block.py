"""The harmonic controller with the dynamic feed-forward (``feedforward: dynamic``).

As :class:`~rotor_avc.harmonic.block.HarmonicController` adapting in the excitations, but the
forces are those of the internal loop (:mod:`.internal_model`) run on the excitation estimate
``C``: per block of ``refresh_samples`` samples its phasors and transient, and the model's
predicted sensor signals, which are subtracted from the measured ones before demodulation. The
demodulated residual ``E = H (C_true - C)`` (the loop's disturbance model ``H``, as seen
without the internal loop's forces) drives the block's law on ``H``; a new estimate starts a
new block at the next sample (the loop that :func:`.lti.excitation_loop_poles` analyses, and
``gain: auto`` follows).

Model error (``influence.phase_error_deg`` / ``magnitude_factor`` of the config, as for the
quasi-steady phasors): the internal model's actuators act ``a = m e^{j phi}`` times as strongly as
the plant's, i.e. the forces the model computes reach the plant as ``1/a`` times those at 1x --
applied to the block's force phasor exactly and to its transient forces (which are not at 1x)
in magnitude, ``1/m``. The prediction stays the model's, so the residual carries the error
``(G_plant - G_model) f`` beside ``H (C_true - C)``; at a constant speed the estimate's loop
is then the quasi-steady one with the law's map off by ``1/a`` (stable for ``|phi|`` below about
90 deg at a moderate gain), and the steady 1x still cancels when it converges.

Limits (anti-windup): at each block's start, when the force phasor's peak plus the block's
largest transient force (or the corresponding slopes) exceeds ``force_limit_n`` (or
``rate_limit_n_per_s``), the estimate and the internal state are scaled down together -- the
internal loop then runs as if the estimate had been the scaled one all along, so forces,
prediction and estimate stay consistent.
"""
from __future__ import annotations

import math
from cmath import rect

import numpy as np

from ..errors import ModelError
from .block import HarmonicController
from .block_settings import HarmonicSettings
from .influence import InfluenceSchedule
from .internal_model import InternalLoop, InternalTables


class DynamicHarmonicController(HarmonicController):
    """``reset()`` / ``step(signals, angle, speed) -> forces`` (module docstring)."""

    def __init__(self, schedule: InfluenceSchedule, sample_period_s: float,
                 settings: HarmonicSettings, tables: InternalTables,
                 model_error: complex = 1.0, name: str = "harmonic"):
        if settings.adapt_in != "excitations" or settings.identify:
            raise ModelError("the dynamic feed-forward adapts the excitation estimate on its "
                             "internal model: it needs adapt_in excitations and no "
                             "identification")
        if not (math.isfinite(abs(model_error)) and abs(model_error) > 0):
            raise ModelError(f"model_error must be a finite nonzero factor (got {model_error})")
        if tables.refresh != settings.refresh_samples or abs(
                tables.sample_period_s - sample_period_s) > 1e-12 * sample_period_s:
            raise ModelError("the internal-model tables were built for another refresh_samples "
                             "or sample rate")
        self._loop = InternalLoop(tables)
        self._r = tables.refresh
        self._to_plant = 1.0 / complex(model_error)
        super().__init__(schedule, sample_period_s, settings, name)

    def reset(self) -> None:
        super().reset()
        self._loop.reset()
        self._j = self._r
        self._restart = False
        n, m = len(self.actuator_ids), len(self.sensors)
        self._F = [0j] * n
        self._ftr = [[0.0] * n] * self._r
        self._pred = [[0.0] * m] * self._r

    @property
    def state(self) -> dict:
        out = super().state
        out.update(j=self._j, restart=self._restart, internal=self._loop.state, F=self._F,
                   ftr=self._ftr, pred=self._pred, preds=list(self._preds))
        return out

    def set_state(self, state: dict) -> None:
        super().set_state(state)
        self._loop.set_state(state["internal"])
        self._j, self._restart, self._F, self._ftr, self._pred = (
            int(state["j"]), bool(state["restart"]), state["F"], state["ftr"], state["pred"])
        self._preds = [float(p) for p in state["preds"]]

    def step(self, signals, angle: float, speed: float) -> list[float]:
        """Sensor signals at ``t_k``, shaft angle (rad) and speed (rad/s) -> forces (N)."""
        if not self._counted_on(speed):
            return self._zero
        j = self._j
        if j >= self._r or self._restart:
            self._start_block(angle, speed, j)
            j = 0
        self._j = j + 1
        self._preds.extend(self._pred[j])
        if self._window_done(signals, angle, speed * self.sample_period_s):
            self._update()
        e = rect(1.0, angle)
        return [(a * e).real + t for a, t in zip(self._F, self._ftr[j])]

    def _clear_window(self) -> None:
        super()._clear_window()
        self._preds: list = []          # the model's predicted signals at the window's samples

    def _window_signals(self) -> np.ndarray:
        """The measured signals minus the internal model's prediction."""
        return super()._window_signals() - np.array(self._preds, dtype=float).reshape(
            -1, len(self.sensors))

    def _may_run(self, k: int, speed: float) -> bool:
        was_on = self.mode != "off"
        on = super()._may_run(k, speed)
        if on != was_on:
            self._loop.reset()
            self._j = self._r
            self._F = [0j] * len(self._zero)
        return on

    def _start_block(self, angle: float, speed: float, elapsed: int) -> None:
        """The internal loop's next block: phasors from the estimate, limits, sequences."""
        s = self.settings
        self._restart = False
        self.U[0], F, ftr, pred = self._loop.advance(self.C, angle, speed, elapsed)
        if self._to_plant != 1.0:
            F, ftr = F * self._to_plant, ftr * abs(self._to_plant)
        if s.force_limit_n == math.inf and s.rate_limit_n_per_s == math.inf:
            self._set_block(F, ftr, pred)
            return
        A = np.abs(F)
        peak = A + np.abs(ftr).max(axis=0)
        slope = speed * A + np.abs(np.diff(ftr, axis=0)).max(axis=0, initial=0.0) \
            / self.sample_period_s
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = float(np.min(np.minimum(
                np.where(peak > 0, s.force_limit_n / peak, 1.0),
                np.where(slope > 0, s.rate_limit_n_per_s / slope, 1.0)), initial=1.0))
        self.saturated = scale < 1.0
        if self.saturated:
            self._loop.scale(scale)
            self.C *= scale
            self.U *= scale
            F, ftr, pred = F * scale, ftr * scale, pred * scale
        self._set_block(F, ftr, pred)

    def _set_block(self, F, ftr, pred) -> None:
        self._F = F.tolist()
        self._ftr = ftr.tolist()
        self._pred = pred.tolist()

    def _update_excitations(self, e: np.ndarray, speed: float) -> None:
        """Adapt the estimate on the disturbance model (the residual's map); a new block starts
        with it at the next sample."""
        A_C, B = self._law(self.schedule.disturbance_at(speed), speed)
        self.C = A_C @ self.C + B @ e
        self._restart = True

    def _limit(self, speed: float) -> None:
        """Limits act at each block's start (:meth:`_start_block`)."""

    def describe(self) -> str:
        a = 1.0 / self._to_plant
        error = "" if a == 1.0 else (f", model error x{abs(a):.3g} at "
                                     f"{math.degrees(math.atan2(a.imag, a.real)):.3g} deg")
        return super().describe() + (f", dynamic feed-forward (internal loop, blocks of "
                                     f"{self._r} samples{error})")
