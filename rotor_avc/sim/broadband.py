"""A broadband test force added to one actuator's commanded force, for measured FRFs (H1/H2).

A scenario may add a known force ``d_k`` to the force the controller of one actuator commands
(or to the zero force of an actuator without a controller)::

    simulation:
      test_signal:
        actuator: DL           # an actuator of the plant
        kind: white            # white: band-limited Gaussian noise; chirp: repeated linear sweep
        rms_n: 200.0           # RMS force (N); white: the expected value
        band_hz: [2.0, 400.0]  # white: Butterworth band-pass edges (order 4; 0 = low-pass);
                               # chirp: start and stop frequency of each sweep
        seed: 1                # white: the random sequence (default 0)
        sweep_s: 1.0           # chirp: duration of one sweep, repeated (default 1 s)

The keys are declared in :class:`rotor_avc.settings.TestSignalSettings`; the actuator and the
band's Nyquist limit are checked here (:func:`broadband_from_config`).

Sampling contract (DESIGN.md section 3): the plant holds ``u_k + d_k`` over ``[t_k, t_k+1)``;
``u_k`` is what the controller answered, ``d_k`` this force. The sequence depends only on the
sample index and the configuration, never on the run's length or on who steps the plant:
:class:`rotor_avc.sim.stepper.PlantStepper` adds it, so the in-process loop and the ROS plant
node apply the same force, and a comparison regenerates it from a bag's configuration.

Recorded as the time-series channel ``test_signal_<id>_f<axis>`` (N) and, in a bag, on the
labelled topic ``/<ns>/plant/test_signal`` (``time_s``, ``test_signal_<id>_f<axis>``) written by
:func:`rotor_avc.recording.write_run_bag`; the ``foot/<id>/actuator_force`` topic stays the
controller's answer ``u_k``.

* white: ``d_k = g (h * w)_k`` with ``w`` standard normal, drawn per block of :data:`BLOCK`
  samples from ``numpy.random.default_rng([seed, block])``, ``h`` the band-pass and ``g`` such
  that the stationary RMS is ``rms_n`` (``g^2 sum h^2 = rms_n^2``, from ``|H|^2`` on a dense grid);
* chirp: ``d_k = sqrt(2) rms_n sin(phase of a linear sweep lo -> hi over sweep_s)`` at
  ``tau = t_k mod sweep_s``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.signal

from ..errors import ModelError
from ..settings import TEST_SIGNAL_KINDS as KINDS, TestSignalSettings

#: samples drawn per random block (the sequence does not depend on it being read in blocks)
BLOCK = 4096
FILTER_ORDER = 4


@dataclass(frozen=True, eq=False)
class BroadbandForce:
    """The test force of one actuator (see the module docstring)."""

    actuator: str
    axis: str
    kind: str
    rms_n: float
    band_hz: tuple[float, float]
    sample_period_s: float
    seed: int = 0
    sweep_s: float = 1.0

    def __post_init__(self):
        lo, hi = (float(f) for f in self.band_hz)
        nyquist = 0.5 / self.sample_period_s
        if self.kind not in KINDS:
            raise ModelError(f"test signal kind {self.kind!r}: use one of {', '.join(KINDS)}")
        if not (math.isfinite(self.rms_n) and self.rms_n > 0):
            raise ModelError(f"test signal rms_n must be > 0 N (got {self.rms_n})")
        if not 0.0 <= lo < hi < nyquist:
            raise ModelError(f"test signal band [{lo:g}, {hi:g}] Hz must satisfy 0 <= lo < hi < "
                             f"{nyquist:g} Hz (the Nyquist frequency)")
        if not (math.isfinite(self.sweep_s) and self.sweep_s > 0):
            raise ModelError(f"test signal sweep_s must be > 0 s (got {self.sweep_s})")
        object.__setattr__(self, "band_hz", (lo, hi))
        object.__setattr__(self, "_blocks", [])          # white: filtered blocks, in order
        if self.kind == "white":
            fs = 1.0 / self.sample_period_s
            sos = (scipy.signal.butter(FILTER_ORDER, [lo, hi], "bandpass", fs=fs, output="sos")
                   if lo > 0 else scipy.signal.butter(FILTER_ORDER, hi, fs=fs, output="sos"))
            _, h = scipy.signal.sosfreqz(sos, worN=1 << 18)
            gain = self.rms_n / math.sqrt(float(np.mean(np.abs(h) ** 2)))
            object.__setattr__(self, "_sos", sos)
            object.__setattr__(self, "_gain", gain)
            object.__setattr__(self, "_zi", np.zeros((sos.shape[0], 2)))

    @property
    def channel(self) -> str:
        """Time-series channel and bag label of the force: ``test_signal_<id>_f<axis>``."""
        return f"test_signal_{self.actuator}_f{self.axis}"

    def describe(self) -> dict:
        out = {"actuator": self.actuator, "kind": self.kind, "rms_n": self.rms_n,
               "band_hz": list(self.band_hz)}
        out.update({"seed": self.seed} if self.kind == "white" else {"sweep_s": self.sweep_s})
        return out

    def values(self, k0: int, n: int) -> np.ndarray:
        """``d_k`` (N) for samples ``k0 .. k0 + n - 1``."""
        if k0 < 0 or n < 0:
            raise ModelError(f"test signal samples must be >= 0 (got k0 = {k0}, n = {n})")
        if self.kind == "chirp":
            tau = np.mod((k0 + np.arange(n)) * self.sample_period_s, self.sweep_s)
            lo, hi = self.band_hz
            return math.sqrt(2.0) * self.rms_n * scipy.signal.chirp(
                tau, lo, self.sweep_s, hi, method="linear", phi=-90.0)
        last = (k0 + n - 1) // BLOCK if n else -1
        while len(self._blocks) <= last:                 # filtered in order, state carried over
            w = np.random.default_rng([self.seed, len(self._blocks)]).standard_normal(BLOCK)
            y, zi = scipy.signal.sosfilt(self._sos, w, zi=self._zi)
            object.__setattr__(self, "_zi", zi)
            self._blocks.append(self._gain * y)
        if not n:
            return np.zeros(0)
        first = k0 // BLOCK
        seq = np.concatenate(self._blocks[first:last + 1])
        return seq[k0 - first * BLOCK:k0 - first * BLOCK + n].copy()


def broadband_from_config(signal: TestSignalSettings, sec, plant,
                          sample_period_s: float) -> BroadbandForce:
    """The force ``simulation.test_signal`` declares (``signal``, read from the
    :class:`rotor_avc.config.Section` ``sec``), its actuator and band checked against the plant
    and the sample rate."""
    ids = [a.id for a in plant.actuators]
    if signal.actuator not in ids:
        raise sec.error("actuator", f"unknown actuator {signal.actuator!r}", fix="use one of: "
                        + (", ".join(ids) or "none (the plant has no actuators)"))
    band = list(signal.band_hz)
    nyquist = 0.5 / sample_period_s
    if not 0.0 <= band[0] < band[1] < nyquist:
        raise sec.error("band_hz", f"{band} Hz must satisfy 0 <= lo < hi < {nyquist:g} Hz (the "
                        "Nyquist frequency of the sample rate)", fix="e.g. [2.0, 400.0]")
    return BroadbandForce(signal.actuator, plant.actuator(signal.actuator).axis, signal.kind,
                          signal.rms_n, signal.band_hz, sample_period_s, signal.seed,
                          signal.sweep_s)
