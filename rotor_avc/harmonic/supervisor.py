"""The harmonic block's supervisor: control that is never left worse than off.

Once per update (never per sample) the supervisor of :class:`~rotor_avc.harmonic.block.
HarmonicController` (``adapt_in: forces``) compares the measured error phasors ``E_k`` (all
harmonics and sensors) with

* the level with control off, ``|E_off|``: the first update after switch-on, measured with zero
  phasors (the window before any force);
* the one-revolution map's prediction with the block's own influence model: from the previous
  update, ``E^_k = E_{k-1} + G^ (A_k - A_{k-1})`` (``A`` the applied phasors; the quasi-steady
  map ``E = P + G A`` of :mod:`.laws`, where every law predicts a decrease).

It falls back when ``|E_k| > |E_off| 10^(margin_db / 20)`` (at once), or when ``|E_k|`` grew in
``growth_revolutions`` updates in a row while above ``|E_off| 10^(watch_db / 20)`` and the
model predicted a decrease each time: a wrong model (the loop's radius ``|1 - (mu / m)
e^{-j phi}|`` exceeds 1 beyond ``acos(mu / 2m)`` of phase error ``phi`` for a magnitude factor
``m``, :func:`.laws.convergence_radius`). Growth far below off is left alone: a converging loop
at a lightly damped resonance rises again for many revolutions (the plant's dynamics, which the
quasi-steady prediction leaves out; Werner 2021 case 2 at 17.2 Hz: from -27 to -13 dB).
Falling back
puts on the best phasors seen (lowest measured ``|E|``) if they were at least 1 dB better than
off, else zero phasors; after ``settle_updates`` updates the held level is measured (above the
margin: zero phasors instead), then the influence matrix is re-identified column by column with
small test phasors ``delta_j = probe_fraction |E_off| / |G^_j|`` on the held ones
(``G_j = (E_j - E_held) / delta_j``, each measured after ``settle_updates`` updates), and
adaptation resumes from the held phasors on the identified matrix. After ``retries``
re-identifications the next fall-back holds for good. Every fall-back is counted and its reason
kept (the block's status, ``harmonic/status`` and ``/diagnostics``).

The comparison needs the speed held: the supervisor judges only while the speed changes by at
most ``speed_tolerance`` (relative) per update, and the level test only near the speed at which
``|E_off|`` was measured (in a sweep the block's ``divergence_factor`` test remains).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..settings import setting

#: the best phasors are held only if at least this much better than off (else zero phasors)
BEST_GAIN_DB = 1.0


@dataclass(frozen=True)
class SupervisorSettings:
    """``harmonic.supervisor``: the fall-back supervisor (module docstring)."""

    enabled: bool = setting(True, "supervise the phasor loop (`adapt_in: forces`)")
    growth_revolutions: int = setting(3, "updates in a row the error may grow while the "
                                      "influence model predicts a decrease", minimum=1)
    margin_db: float = setting(3.0, "error above the level with control off that falls back at "
                               "once", unit="dB", positive=True)
    watch_db: float = setting(-6.0, "the growth test counts only while the error is above the "
                              "level with control off by this (a converged loop's transients "
                              "below it are left alone)", unit="dB", maximum=0.0)
    probe_fraction: float = setting(0.1, "re-identification test phasor: its predicted "
                                    "vibration as a fraction of the level with control off",
                                    positive=True, maximum=1.0)
    settle_updates: int = setting(3, "updates held phasors and each test phasor settle before "
                                  "they are measured", minimum=1)
    retries: int = setting(2, "re-identifications before a fall-back holds for good",
                           minimum=0)
    speed_tolerance: float = setting(0.005, "relative speed change per update up to which the "
                                     "speed counts as held", positive=True, maximum=1.0)


class Supervisor:
    """Per update: :meth:`observe` -> phasors to hold (the law skipped) or None (adapt)."""

    def __init__(self, settings: SupervisorSettings):
        self.settings = settings
        self.fallbacks = 0
        self.first_fallback = None      # updates from switch-on to the first fall-back
        self.restart()

    def restart(self) -> None:
        """Switch-on: forget the levels and the sequence (the fall-back count stays)."""
        self.off = None                 # (|E_off| per harmonic, speed)
        self.off_norm = 0.0             # |E_off| over all harmonics
        self.best = None                # (|E|, A)
        self.prev = None                # (E, A, speed)
        self.grow = 0
        self.plan: list = []            # the fall-back's remaining steps
        self.hold = None
        self.base = None
        self.columns: list = []
        self.delta = self.applied = None
        self.countdown = 0
        self.identified = None
        self.mode, self.reason = "adapting", ""
        self.updates = 0

    @property
    def busy(self) -> bool:
        """True from a fall-back until adaptation resumes."""
        return self.hold is not None

    @property
    def state(self) -> dict:
        return {k: _copy(v) for k, v in vars(self).items() if k != "settings"}

    def set_state(self, state: dict) -> None:
        for k, v in state.items():
            setattr(self, k, _copy(v))

    def observe(self, E: np.ndarray, A: np.ndarray, estimate: np.ndarray, speed: float):
        """This update's error ``E`` (H, M) with phasors ``A`` (H, N) applied, the influence
        estimate (H, M, N): the phasors to hold next (and :attr:`mode`), or None to adapt."""
        s = self.settings
        norm = norm2(E)
        self.updates += 1
        if self.off is None:
            self.off = (np.linalg.norm(E, axis=1), speed)
            self.off_norm = norm
        if self.busy:
            return self._sequence(E, A, estimate, speed)
        if self.best is None or norm < self.best[0]:
            self.best = (norm, A.copy())
        prev, self.prev = self.prev, (E.copy(), A.copy(), speed)
        off_norm = self.off_norm
        if abs(speed / self.off[1] - 1) <= s.speed_tolerance \
                and norm > off_norm * 10 ** (s.margin_db / 20):
            return self._fall_back(f"error {_db(norm, off_norm):.1f} dB above the level with "
                                   "control off", off_norm)
        if prev is None or abs(speed / prev[2] - 1) > s.speed_tolerance:
            self.grow = 0
            return None
        E0, A0, _ = prev
        before = norm2(E0)
        predicted = norm2(E0 + (estimate @ (A - A0)[:, :, None])[:, :, 0])
        watched = norm > off_norm * 10 ** (s.watch_db / 20)
        self.grow = self.grow + 1 if watched and norm > before and predicted < before else 0
        if self.grow >= s.growth_revolutions:
            return self._fall_back(f"error grew {self.grow} updates in a row where the "
                                   "influence model predicted a decrease", off_norm)
        return None

    def _fall_back(self, why: str, off_norm: float) -> np.ndarray:
        s = self.settings
        self.fallbacks += 1
        if self.first_fallback is None:
            self.first_fallback = self.updates
        best, A = self.best
        if _db(best, off_norm) <= -BEST_GAIN_DB:
            self.hold, kept = A.copy(), f"held the best phasors ({_db(best, off_norm):.1f} dB)"
        else:
            self.hold, kept = np.zeros_like(A), "zero phasors"
        final = self.fallbacks > s.retries
        self.reason = (f"supervisor fall-back {self.fallbacks}: {why}; {kept}"
                       + ("; holding for good" if final else "; re-identifying"))
        self.plan = [] if final else ["base"] + list(range(A.shape[1]))
        return self._wait(self.hold, final)

    def _wait(self, applied: np.ndarray, final: bool = False) -> np.ndarray:
        """Apply ``applied`` for ``settle_updates`` updates."""
        self.mode = "frozen" if final else "identifying"
        self.countdown, self.applied = self.settings.settle_updates, applied
        return applied

    def _sequence(self, E, A, estimate, speed) -> np.ndarray | None:
        """Held phasors, then the test phasors, one actuator at a time, then adapt again."""
        self.countdown -= 1
        if self.countdown > 0 or not self.plan:            # settling, or held for good
            return self.applied
        s = self.settings
        step = self.plan.pop(0)
        off = self.off[0]
        if step == "base":
            if norm2(E) > self.off_norm * 10 ** (s.margin_db / 20) \
                    and np.any(self.hold):
                self.hold = np.zeros_like(self.hold)
                self.reason += "; held level above the margin: zero phasors"
                self.plan.insert(0, "base")
                return self._wait(self.hold)
            self.base, self.columns = E.copy(), []
        else:
            self.columns.append((E - self.base) / self.delta[:, None])
        if self.plan:
            j = self.plan[0]
            cols = np.linalg.norm(estimate[:, :, j], axis=1)
            self.delta = s.probe_fraction * off / np.where(cols > 0, cols, 1.0)
            probe = self.hold.copy()
            probe[:, j] += self.delta
            return self._wait(probe)
        self.identified = np.stack(self.columns, axis=2)
        hold, self.hold = self.hold, None
        self.prev, self.grow, self.mode = None, 0, "adapting"
        self.reason += "; re-identified, adapting again"
        return hold


def norm2(x: np.ndarray) -> float:
    """The 2-norm of an array's entries (``np.linalg.norm`` without its per-call checks)."""
    return math.sqrt(np.vdot(x, x).real)


def _db(level: float, ref: float) -> float:
    return 20 * math.log10(max(level, 1e-300) / max(ref, 1e-300))


def _copy(v):
    if isinstance(v, np.ndarray):
        return v.copy()
    if isinstance(v, (tuple, list)):
        return type(v)(_copy(x) for x in v)
    return v
