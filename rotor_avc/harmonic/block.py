"""The adaptive harmonic controller block: actuator forces locked to the shaft angle.

At sample ``k`` (DESIGN.md section 3) the block takes the sensor signals ``e_k`` (M), the shaft
angle ``theta_k`` and speed ``Omega_k``, and returns the forces (N actuators) to hold over
``[t_k, t_k+1)``::

    u_k = sum_h Re{A_h e^{j h theta_k}},     A_h = U_h + D_h     (D: identification dither)

It demodulates the signals over an update window (one revolution, or ``update_every_samples``)::

    E_h = 2 sum_k e_k e^{-j h theta_k} w_k / sum_k w_k,     w_k = Omega_k T

(angle weighting: an exact Fourier coefficient over a revolution whatever the speed does), and at
the window's last sample updates the phasors by the law of :mod:`rotor_avc.harmonic.laws` with
the influence estimate ``G^_h(Omega)`` = speed schedule (:mod:`.influence`) + the online
correction (:mod:`.identification`), before answering that sample. The dither's own response
``G^ D`` is removed from ``E`` before the law acts.

Adapting in the excitations (``adapt_in: excitations``, 1x): the law acts on an estimate ``C``
of the plant's synchronous excitation amplitudes (the unbalance) instead of on ``U``: with the
disturbance model ``H(Omega)`` (sensor response per unit excitation) the phasors are
``U = -pinv(G^) H C``, leaving ``E = K (C_true - C)`` with ``K = G^ pinv(G^) H``, and the law of
:mod:`.laws` runs on ``K``. At a constant speed this is the same loop (for ``K`` invertible,
``U+ = U - mu pinv(G^) E``, Newton), but the estimate is speed-invariant: during a run-up the
phasors follow the scheduled ``G`` and ``H`` through every resonance (recomputed every
``refresh_samples`` samples), instead of having to be re-learnt -- the Zhou & Shi 2001 balancer plane
(an RLS estimate of the unbalance) and the Sci. Rep. 2023 quantified force, in harmonic form.

Limits (anti-windup by projection): per actuator the peak force ``sum_h |A_h|`` is kept within
``force_limit_n`` and the peak slope ``sum_h h Omega |A_h|`` within ``rate_limit_n_per_s`` by
scaling the stored phasors themselves, so the adaptation never winds up beyond the limit.

Supervisor (:mod:`.supervisor`, ``adapt_in: forces``, on by default): per update it compares the
error with the level with control off and its model's prediction, falls back to the best phasors
seen (or zero), re-identifies the influence matrix with test phasors and adapts again.

Safe fallback: the loop is taken to diverge when ``|E| / Omega^2`` exceeds ``divergence_factor``
times its value at switch-on (an unbalance response grows with ``Omega^2``; the default 100
leaves room for a resonance's amplification during a run-up), and the estimate to be poor when
the identification's prediction residual stays above ``poor_residual`` for ``patience`` updates; then the block stops adapting and either
holds its phasors (``freeze``) or fades them out over about ``fade_updates`` updates (``fade``),
and reports it in :attr:`status` until :meth:`reset`.

The block is off (zero force, no adaptation) before ``start_s``, below ``min_speed_hz`` and
outside the influence schedule; switching on starts from zero phasors. Per sample it is plain
Python floats; numpy runs once per update.
"""
from __future__ import annotations

import math
from cmath import rect

import numpy as np

from ..errors import ModelError
from .identification import InfluenceRls
from .influence import InfluenceSchedule
from .block_settings import HarmonicSettings
from .laws import update_matrices
from .supervisor import Supervisor, norm2

MODES = ("off", "adapting", "frozen", "fading", "identifying")
TWO_PI = 2 * math.pi


class HarmonicController:
    """``reset()`` / ``step(signals, angle, speed) -> forces`` (module docstring)."""

    def __init__(self, schedule: InfluenceSchedule, sample_period_s: float,
                 settings: HarmonicSettings = HarmonicSettings(), name: str = "harmonic"):
        settings.check()
        if not (math.isfinite(sample_period_s) and sample_period_s > 0):
            raise ModelError(f"sample_period_s must be > 0 (got {sample_period_s})")
        m, n = len(schedule.sensors), len(schedule.actuators)
        if settings.sensor_weights is not None and len(settings.sensor_weights) != m:
            raise ModelError(f"sensor_weights needs {m} entries, one per sensor")
        if settings.adapt_in == "excitations" and (schedule.disturbance is None
                                                   or schedule.harmonics != (1,)):
            raise ModelError("adapt_in excitations needs the 1x harmonic alone and a schedule "
                             "with the disturbance model")
        self.schedule = schedule
        self.settings = settings
        self.name = name
        self.sample_period_s = float(sample_period_s)
        self.sensors = schedule.sensors
        self.actuator_ids = schedule.actuators
        self.harmonics = schedule.harmonics
        self._one = self.harmonics == (1,)
        self._shape = (len(self.harmonics), m, n)
        # the speeds it runs at: from min_speed_hz, inside the schedule
        self._min_speed = max(TWO_PI * settings.min_speed_hz, float(schedule.speeds_rad_s[0]))
        self._max_speed = float(schedule.speeds_rad_s[-1])
        self._start_k = math.ceil(settings.start_s / self.sample_period_s - 1e-9)
        self._refresh = settings.refresh_samples if settings.adapt_in == "excitations" else 0
        self._every = settings.update_every_samples
        self._supervise = settings.supervisor.enabled and settings.adapt_in == "forces"
        self.reset()

    # -- state -------------------------------------------------------------------------------
    def reset(self) -> None:
        """Off, zero phasors, a fresh estimate and dither sequence, fallback cleared."""
        H, m, n = self._shape
        s = self.settings
        self.k = 0
        self.mode = "off"
        self.reason = "not started"
        self.U = np.zeros((H, n), complex)
        self.D = np.zeros((H, n), complex)
        self.E = np.zeros((H, m), complex)
        self.C = np.zeros(len(self.schedule.excitations), complex)
        self._since_refresh = 0
        self.estimate = np.zeros((H, m, n), complex)
        self.rls = [InfluenceRls(m, n, s.forgetting, s.min_change_n, s.min_rel_change)
                    for _ in range(H)]
        self._rng = np.random.default_rng(s.seed)
        self._prev: tuple[np.ndarray, np.ndarray] | None = None
        self._ref = None
        self._poor = 0
        self.n_updates = 0
        self.saturated = False
        self.supervisor = Supervisor(s.supervisor) if self._supervise else None
        self._laws: dict = {}
        self._clear_window()
        self._set_outputs()

    def _clear_window(self) -> None:
        self._sig: list = []            # the window's samples: signals (flat), angles, angle steps
        self._ang: list = []
        self._w: list = []
        self._span = 0.0

    def _set_outputs(self) -> None:
        A = self.U + self.D
        self._out = A.tolist()
        self._zero = [0.0] * self._shape[2]

    @property
    def state(self) -> dict:
        """Everything the next steps depend on (arrays copied)."""
        return {"k": self.k, "mode": self.mode, "reason": self.reason, "U": self.U.copy(),
                "D": self.D.copy(), "E": self.E.copy(), "C": self.C.copy(),
                "window": (list(self._sig), list(self._ang), list(self._w)),
                "span": self._span, "ref": self._ref, "poor": self._poor,
                "n_updates": self.n_updates,
                "prev": None if self._prev is None else tuple(a.copy() for a in self._prev),
                "rls": [(r.correction.copy(), r.covariance.copy(), r.residual, r.n_updates)
                        for r in self.rls],
                "rng": self._rng.bit_generator.state,
                "supervisor": None if self.supervisor is None else self.supervisor.state}

    def set_state(self, state: dict) -> None:
        """Restore a :attr:`state`."""
        H, m, n = self._shape
        U, D = np.asarray(state["U"], complex), np.asarray(state["D"], complex)
        sig, ang, w = state["window"]
        if U.shape != (H, n) or D.shape != (H, n) or not len(sig) == m * len(ang) == m * len(w) \
                or state["mode"] not in MODES:
            raise ModelError(f"harmonic state does not fit {H} harmonics x {m} sensors x "
                             f"{n} actuators")
        self.k, self.mode, self.reason = int(state["k"]), state["mode"], state["reason"]
        self.U, self.D, self.E = U.copy(), D.copy(), np.asarray(state["E"], complex).copy()
        self.C = np.asarray(state["C"], complex).copy()
        self._sig, self._ang, self._w = [float(v) for v in sig], list(ang), list(w)
        self._span = float(state["span"])
        self._ref, self._poor, self.n_updates = state["ref"], state["poor"], state["n_updates"]
        self._prev = None if state["prev"] is None else tuple(a.copy() for a in state["prev"])
        for r, (corr, cov, res, nu) in zip(self.rls, state["rls"]):
            r.correction, r.covariance, r.residual, r.n_updates = corr.copy(), cov.copy(), res, nu
        self._rng.bit_generator.state = state["rng"]
        if self.supervisor is not None:
            self.supervisor.set_state(state["supervisor"])
        self._set_outputs()

    @property
    def status(self) -> dict:
        """Mode, reason, error and force phasor magnitudes, estimate residuals (for reports,
        the status topic and ``/diagnostics``)."""
        return {"mode": self.mode, "reason": self.reason, "updates": self.n_updates,
                "error_abs": np.abs(self.E).tolist(), "force_abs_n": np.abs(self.U).tolist(),
                "saturated": self.saturated, "fallbacks": getattr(self.supervisor, "fallbacks", 0),
                "residual": [r.residual for r in self.rls],
                "excitation_estimate": {e: [c.real, c.imag] for e, c in
                                        zip(self.schedule.excitations, self.C.tolist())}}

    # -- stepping ----------------------------------------------------------------------------
    def step(self, signals, angle: float, speed: float) -> list[float]:
        """Sensor signals at ``t_k``, shaft angle (rad) and speed (rad/s) -> forces (N).

        Per sample the window keeps the signals, the angle and its step, and the forces are one
        complex product per actuator and harmonic; the demodulation runs once per update
        (:meth:`_demodulate`)."""
        k = self.k
        self.k = k + 1
        if (self.mode == "off" or not self._min_speed <= speed <= self._max_speed) \
                and not self._may_run(k, speed):
            return self._zero
        w = speed * self.sample_period_s
        self._sig.extend(signals)
        self._ang.append(angle)
        self._w.append(w)
        self._span += w
        if (len(self._w) >= self._every) if self._every else self._span >= TWO_PI:
            self._update()
        elif self._refresh:
            self._since_refresh += 1
            if self._since_refresh >= self._refresh and self.mode == "adapting":
                self._synthesise(speed)
        if self._one:
            e = rect(1.0, angle)
            return [(a * e).real for a in self._out[0]]
        forces = list(self._zero)
        for h, phasors in zip(self.harmonics, self._out):
            e = rect(1.0, h * angle)
            for j, a in enumerate(phasors):
                forces[j] += (a * e).real
        return forces

    def _counted_on(self, speed: float) -> bool:
        """Count the sample; switch on or off at it (:meth:`_may_run`); True while on."""
        k = self.k
        self.k = k + 1
        if self.mode == "off" or not self._min_speed <= speed <= self._max_speed:
            return self._may_run(k, speed)
        return True

    def _window_done(self, signals, angle: float, w: float) -> bool:
        """Keep a sample (angle step ``w``) in the window; True at the window's last sample."""
        self._sig.extend(signals)
        self._ang.append(angle)
        self._w.append(w)
        self._span += w
        every = self._every
        return (len(self._w) >= every) if every else (self._span >= TWO_PI)

    def _window_signals(self) -> np.ndarray:
        """The window's signals (samples, sensors) that are demodulated."""
        return np.array(self._sig, dtype=float).reshape(-1, self._shape[1])

    def _demodulate(self) -> np.ndarray:
        """``E_h = 2 sum_k e_k e^{-j h theta_k} w_k / sum_k w_k`` (H, M) over the window
        (module docstring)."""
        S = self._window_signals()
        h = np.asarray(self.harmonics, dtype=float)[:, None]
        Z = np.asarray(self._w) * np.exp(-1j * h * np.asarray(self._ang))
        E = (2.0 / self._span) * (Z @ S)
        if not np.isfinite(E).all():               # a non-finite sample reaches E (w_k > 0)
            bad = ~np.all(np.isfinite(S), axis=0)
            raise ModelError(f"{self.name}: non-finite signal of "
                             f"{', '.join(np.asarray(self.sensors)[bad])} in the last window "
                             "(sensor fault?)")
        return E

    def _may_run(self, k: int, speed: float) -> bool:
        """Switch on (from zero) or off at this sample; True while on."""
        on = (k >= self._start_k and speed >= self._min_speed
              and self.schedule.covers(speed))
        if on and self.mode == "off":
            self.mode, self.reason = "adapting", "switched on"
            if self.supervisor is not None:
                self.supervisor.restart()
            self._clear_window()
        elif not on and self.mode != "off":
            self.U[:] = 0.0
            self.D[:] = 0.0
            self.C[:] = 0.0
            self._prev = None
            self._ref = None
            self.mode, self.reason = "off", "below min_speed_hz or outside the schedule"
            self._set_outputs()
        return on

    def _update(self) -> None:
        """End of a window: phasors, identification, fallback checks, law, limits."""
        H, m, n = self._shape
        E = self._demodulate()
        speed = self._span / (len(self._w) * self.sample_period_s)
        self._clear_window()
        self.E = E
        self.n_updates += 1
        prior = self.schedule.at(speed)
        A = self.U + self.D
        s = self.settings
        if s.identify and self._prev is not None:
            A_prev, E_prev = self._prev
            learned = [r.update(A[hi] - A_prev[hi], E[hi] - E_prev[hi], prior[hi],
                                float(np.linalg.norm(A_prev[hi])))
                       for hi, r in enumerate(self.rls)]
            if any(learned):
                worst = max(r.residual for r, ok in zip(self.rls, learned) if ok)
                self._poor = self._poor + 1 if worst > s.poor_residual else 0
        self._prev = (A.copy(), E.copy())
        self.estimate = prior + np.array([r.correction for r in self.rls])
        norm = norm2(E)
        if self._ref is None:
            self._ref = norm / speed**2
        if self.mode == "adapting":
            growth = norm / max(self._ref * speed**2, 1e-300)
            if not growth <= s.divergence_factor:
                self._fall_back(f"diverging: |E| / Omega^2 grew {growth:.3g} times its value "
                                "at switch-on")
            elif self._poor >= s.patience:
                self._fall_back(f"poor estimate: prediction residual above {s.poor_residual:g} "
                                f"for {self._poor} updates")
        if self._supervised(E, A, prior, speed):
            pass
        elif self.mode == "adapting" and s.adapt_in == "excitations":
            self._update_excitations(E[0] - self.estimate[0] @ self.D[0], speed)
        elif self.mode == "adapting":
            for hi in range(H):
                A_U, B = self._law(self.estimate[hi], speed)
                e = E[hi] - self.estimate[hi] @ self.D[hi]
                self.U[hi] = A_U @ self.U[hi] - B @ e
        if self.mode == "adapting":
            if s.dither_n > 0:
                self.D = s.dither_n * np.exp(2j * np.pi * self._rng.random((H, n)))
        elif self.mode == "fading":
            self.U *= 1.0 - 1.0 / s.fade_updates
            self.C *= 1.0 - 1.0 / s.fade_updates
            self.D[:] = 0.0
        self._limit(speed)
        self._set_outputs()

    def _supervised(self, E, A, prior, speed: float) -> bool:
        """The supervisor's turn (:mod:`.supervisor`): True when it set the phasors."""
        sup = self.supervisor
        if sup is None or not (self.mode == "adapting" or sup.busy):
            return False
        hold = sup.observe(E, A, self.estimate, speed)
        if sup.identified is not None:
            for hi, r in enumerate(self.rls):
                r.correction = sup.identified[hi] - prior[hi]
            self.estimate, sup.identified = sup.identified, None
        if hold is None:
            return False
        self.U, self.mode, self.reason = hold.copy(), sup.mode, sup.reason
        self.D[:] = 0.0
        return True

    def _law(self, G: np.ndarray, speed: float) -> tuple[np.ndarray, np.ndarray]:
        """The law's ``(A, B)`` (:func:`.laws.update_matrices`) on ``G`` at this speed's gain,
        kept while ``G`` and the gain repeat (a steady speed without identification)."""
        gain = self.gain_at(speed)
        key = (G.tobytes(), gain)
        hit = self._laws.get(key)
        if hit is None:
            s = self.settings
            hit = update_matrices(G, s.law, gain, effort_weight=s.effort_weight,
                                  leakage=s.leakage, sensor_weights=s.sensor_weights)
            if len(self._laws) >= 16:
                self._laws.clear()
            self._laws[key] = hit
        return hit

    def gain_at(self, speed: float) -> float:
        """The adaptation gain at this speed (the schedule's nearest node, else ``gain``)."""
        s = self.settings
        if not s.gain_values:
            return s.gain
        i = int(np.argmin(np.abs(np.log(np.asarray(s.gain_speeds_rad_s) / speed))))
        return s.gain_values[i]

    def _source_map(self, speed: float) -> tuple[np.ndarray, np.ndarray]:
        """``(F, K)``: the phasors ``U = -F C`` that cancel the estimated excitations ``C`` at this
        speed, and the error they leave per unit estimate error, ``E = K (C_true - C)``."""
        G = self.schedule.at(speed)[0] + self.rls[0].correction
        Hd = self.schedule.disturbance_at(speed)
        F = np.linalg.pinv(G) @ Hd
        return F, G @ F

    def _update_excitations(self, e: np.ndarray, speed: float) -> None:
        """Adapt the excitation estimate (the law acting on ``K``), then the phasors from it."""
        A_C, B = self._law(self._source_map(speed)[1], speed)
        self.C = A_C @ self.C + B @ e
        self._synthesise(speed, limit=False)

    def _synthesise(self, speed: float, limit: bool = True) -> None:
        """Phasors from the excitation estimate at the current speed (speed scheduling within
        a window); with ``limit``, into the limits and onto the outputs."""
        self._since_refresh = 0
        self.U[0] = -self._source_map(speed)[0] @ self.C
        if limit:
            self._limit(speed)
            self._set_outputs()

    def _fall_back(self, reason: str) -> None:
        self.mode = "fading" if self.settings.fallback == "fade" else "frozen"
        self.reason = reason
        self.D[:] = 0.0

    def _limit(self, speed: float) -> None:
        """Scale each actuator's phasors into the force and slope limits (anti-windup)."""
        s = self.settings
        if s.force_limit_n == math.inf and s.rate_limit_n_per_s == math.inf:
            self.saturated = False
            return
        A = np.abs(self.U + self.D)
        h = np.array(self.harmonics, dtype=float)[:, None]
        peak = A.sum(axis=0)
        slope = (h * speed * A).sum(axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.minimum(1.0, np.minimum(np.where(peak > 0, s.force_limit_n / peak, 1.0),
                                               np.where(slope > 0, s.rate_limit_n_per_s / slope,
                                                        1.0)))
        self.saturated = bool(np.any(scale < 1.0))
        if self.saturated:
            self.U *= scale
            self.D *= scale
            self.C *= scale.min()              # the estimate behind the phasors, likewise

    def describe(self) -> str:
        s = self.settings
        every = (f"every {s.update_every_samples} samples" if s.update_every_samples
                 else "once per revolution")
        extra = ", online identification" if s.identify else ""
        return (f"{self.name}: harmonics {list(self.harmonics)}, law {s.law} (gain "
                f"{'scheduled over speed' if s.gain_values else format(s.gain, 'g')}), "
                f"{len(self.actuator_ids)} actuators x {len(self.sensors)} sensors, "
                f"update {every}{extra}")

