"""What a calibration fits to: the measured points of each recording, with their uncertainty,
and the model's prediction of the same points for any machine.

The measurement is the comparison's own (rotor_avc.compare.comparison): the 1x phasor per
dwell (or run-up window) and channel from order tracking, per unit of the run's unbalance, with
``sigma``, the standard error of each quadrature component from the residual of its
least-squares fit; and, where the run had a test force, H1 per coherent bin with its normalised
random error (Bendat & Piersol, ``eps = sqrt(1 - coh) / (|coh|^0.5 sqrt(2 n_d))``). Left out, and
listed: 1x points that had not settled (the phasor drifts more than the comparison's
``SETTLE_TOL`` across its window), the 1x points of a run with a test force (whose response at
the rotational frequency adds to them), bins below the comparison's coherence limit.

Each point's standard uncertainty is ``hypot(sigma, drift |Y|, point |Y|)``: the random error;
for a dwell, the relative change of the phasor between the two halves of its window (a transient
not yet decayed biases the estimate by about that much, which no noise model shows); and
``point``, the relative error of an estimate that neither shows (leakage of what is left of a
transient, the resampling's interpolation, stamp jitter: ``--point-uncertainty``, default
:data:`DEFAULT_POINT_UNCERTAINTY`); at least ``RESOLUTION |Y|``. What no averaging removes, a
sensor's calibration error, is common to all points of one channel:
rotor_avc.calibration.problem models it as one complex gain per channel.

The model of a point is the sampled closed loop (what the comparison rates) of the machine
being fitted, in the recording's scenario (sample rate, damping rule, unbalance, test force):
``sum_j G_j(Omega) u_j / u_ref`` for the 1x points, the transfer from the test force for H1 as a
Welch estimate sees it: averaged over the spectral window of its segments,
``E[H1](f) = sum_k K(nu_k) H(f - nu_k)`` with ``K = |W|^2`` of the data window (normalised;
:data:`KERNEL_BINS` bins either side in :data:`KERNEL_STEPS` steps per bin) -- for a white test
force the expected cross spectrum is the FRF smoothed by the window's power kernel (Bendat &
Piersol, random data, sec. 8.5), so a lightly damped peak narrower than a few bins is compared
with what the estimate can show (its resolution bias) instead of biasing the damping fitted.
Bins closer than :data:`KERNEL_BINS` bins to the test band's edges (where the force's spectrum is
not flat) are left out.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import scipy.signal

from ..analysis.frf_estimate import h1_random_error
from ..analysis.loop_responses import force_response
from ..compare.checks import HARMONIC, MIN_COHERENCE, SETTLE_TOL
from ..compare.comparison import Comparison, model_loops, unbalance_models
from ..errors import ModelError

#: the smallest relative uncertainty of a point (the numerical resolution of a noise-free one)
RESOLUTION = 1e-9
#: default relative uncertainty of a point that its random error and drift do not show
DEFAULT_POINT_UNCERTAINTY = 0.005
#: the spectral window's kernel: bins either side, steps per bin
KERNEL_BINS, KERNEL_STEPS = 3, 8


@dataclass
class BandPoints:
    """The coherent H1 bins of one broadband dwell (a recording: the sampled loop, ``w_F`` as
    the run froze it) or of measured FRFs (``continuous``: the continuous loop with the
    hysteretic model, ``w_F = max(w, floor)`` per frequency)."""

    speed_rad_s: float
    w_F: float | None
    actuator: str
    outputs: list[str]
    freq_hz: np.ndarray
    h1: np.ndarray                   # (bins, outputs)
    sigma: np.ndarray                # (bins, outputs), absolute
    used: np.ndarray                 # (bins, outputs) bool
    continuous: bool = False
    #: ``(offsets_hz, weights)`` of the estimate's spectral window (None: none, a model FRF)
    kernel: tuple | None = None

    def _transfer(self, loops: dict, f: np.ndarray) -> np.ndarray:
        loop = loops["continuous" if self.continuous else "sampled"]
        w_F = (np.maximum(2 * np.pi * f, loop.plant.forced_damping_frequency(0.0))
               if self.continuous else self.w_F)
        frf = force_response(loop, self.speed_rad_s, f, self.actuator, self.outputs, w_F)
        return np.column_stack([frf.responses[o] for o in self.outputs])

    def model(self, loops: dict) -> np.ndarray:
        """The model's ``(bins, outputs)`` transfer from the actuator's force, as the estimate
        sees it (module docstring)."""
        if self.kernel is None:
            return self._transfer(loops, self.freq_hz)
        offsets, weights = self.kernel
        f = (self.freq_hz[:, None] - offsets[None, :]).ravel()
        H = self._transfer(loops, np.abs(f))
        H = np.where(f[:, None] < 0, np.conj(H), H)          # H(-f) = H(f)^* (a real system)
        return np.einsum("fko,k->fo", H.reshape(self.freq_hz.size, offsets.size, -1), weights)


@dataclass
class Target:
    """One recording's measured points (``speeds`` x ``channels`` 1x phasors, per unit of
    ``u_ref``; broadband bins) and the scenario their model lives in."""

    name: str
    scenario: object
    u_ref: complex
    speed_rad_s: np.ndarray
    channels: list[str]
    units: dict[str, str]
    measured: dict[str, np.ndarray]
    sigma: dict[str, np.ndarray]
    #: relative drift of each 1x phasor across its window (zero for run-up windows)
    drift: dict[str, np.ndarray]
    used: dict[str, np.ndarray]
    band: list[BandPoints] = field(default_factory=list)
    left_out: list[str] = field(default_factory=list)

    @property
    def points(self) -> int:
        """Complex points used."""
        return (sum(int(u.sum()) for u in self.used.values())
                + sum(int(b.used.sum()) for b in self.band))

    def measured_vector(self, point: float) -> tuple[np.ndarray, np.ndarray]:
        """``(measured, uncertainty)`` of every used point, in :meth:`predicted`'s order
        (``point``: the relative point uncertainty, module docstring)."""
        y, s = [], []
        for ch in self.channels:
            use = self.used[ch]
            y.append(self.measured[ch][use])
            s.append(np.hypot(self.sigma[ch][use], self.drift[ch][use] * np.abs(y[-1])))
        for b in self.band:
            y.append(b.h1.T[b.used.T])
            s.append(b.sigma.T[b.used.T])
        y = np.concatenate(y) if y else np.zeros(0, complex)
        s = np.concatenate(s) if s else np.zeros(0)
        return y, np.maximum(np.hypot(s, point * np.abs(y)), RESOLUTION * np.abs(y))

    def point_channels(self) -> list[str]:
        """The channel (sensor) of every used point, in :meth:`predicted`'s order."""
        out = [ch for ch in self.channels for _ in range(int(self.used[ch].sum()))]
        for b in self.band:
            out += [o for i, o in enumerate(b.outputs) for _ in range(int(b.used[:, i].sum()))]
        return out

    def loops(self, machine) -> tuple:
        """``(scenario, loops)``: ``machine`` in this recording's scenario (None for measured
        FRFs) and the closed loops its points need."""
        kinds = (["sampled"] if self.channels or any(not b.continuous for b in self.band)
                 else []) + (["continuous"] if any(b.continuous for b in self.band) else [])
        if self.scenario is None:
            return None, model_loops(machine, 0.0, kinds)
        scenario = dataclasses.replace(self.scenario, machine=machine)
        return scenario, model_loops(machine, scenario.sample_period_s, kinds)

    def one_x(self, machine, speed_rad_s) -> dict[str, np.ndarray]:
        """The sampled-loop model's 1x of every channel at ``speed_rad_s`` (per ``u_ref``)."""
        scenario, loops = self.loops(machine)
        return unbalance_models(scenario, {"sampled": loops["sampled"]}, speed_rad_s, self.u_ref,
                                self.channels)["sampled"]

    def predicted(self, machine) -> np.ndarray:
        """The model of every used point for ``machine`` (module docstring)."""
        scenario, loops = self.loops(machine)
        out = []
        if self.channels:
            model = unbalance_models(scenario, {"sampled": loops["sampled"]}, self.speed_rad_s,
                                     self.u_ref, self.channels)["sampled"]
            out += [model[ch][self.used[ch]] for ch in self.channels]
        out += [b.model(loops).T[b.used.T] for b in self.band]
        return np.concatenate(out) if out else np.zeros(0, complex)


def _one_x(comp: Comparison, name: str, left_out: list[str]):
    one = comp.one_x
    if one is None:
        return np.zeros(0), [], {}, {}, {}, {}
    if any(ch.startswith(HARMONIC) for ch in one.measured):
        raise ModelError(f"{name}: the run had the harmonic controller, whose forces the "
                         "calibration's unbalance model does not describe; calibrate with a "
                         "run without it")
    channels = list(one.measured)
    speeds = one.speed_rad_s
    used, drifts = {}, {}
    for ch in channels:
        ok = np.isfinite(one.measured[ch]) & np.isfinite(one.sigma[ch])
        drift = one.drift.get(ch)
        drifts[ch] = np.zeros(speeds.size) if drift is None else np.nan_to_num(drift)
        if drift is not None:
            for k in np.flatnonzero(ok & (drift > SETTLE_TOL)):
                left_out.append(f"{name}: 1x of {ch} at {speeds[k] / (2 * np.pi):.4g} Hz not "
                                f"settled (drift {drift[k]:.2g} > {SETTLE_TOL:g})")
            ok &= ~(drift > SETTLE_TOL)
        used[ch] = ok
    return (speeds, channels, {ch: one.measured[ch] for ch in channels},
            {ch: one.sigma[ch] for ch in channels}, drifts, used)


def spectral_kernel(est) -> tuple[np.ndarray, np.ndarray]:
    """``(offsets_hz, weights)``: the power kernel ``|W(nu)|^2`` of the estimate's data window,
    normalised, over :data:`KERNEL_BINS` bins either side (module docstring)."""
    window = scipy.signal.get_window(est.window, est.nperseg)
    steps = KERNEL_BINS * KERNEL_STEPS
    offsets = np.arange(-steps, steps + 1) * est.resolution_hz / KERNEL_STEPS
    n = np.arange(est.nperseg)
    W = np.exp(-2j * np.pi * np.outer(offsets / est.fs_hz, n)) @ window
    weights = np.abs(W) ** 2
    return offsets, weights / weights.sum()


def _band(comp: Comparison, name: str, left_out: list[str]) -> list[BandPoints]:
    out = []
    actuator = comp.run.scenario.test_force.actuator if comp.broadband else ""
    for bb in comp.broadband:
        est, (lo, hi) = bb.estimate, bb.band_hz
        sel = (est.freq_hz >= max(lo, est.resolution_hz)) & (est.freq_hz <= hi)
        edge = KERNEL_BINS * est.resolution_hz
        inside = (est.freq_hz[sel] >= lo + edge) & (est.freq_hz[sel] <= hi - edge)
        coh = est.coherence[sel]
        used = (coh >= MIN_COHERENCE) & inside[:, None]
        if (~inside).any():
            left_out.append(f"{name}: {int((~inside).sum())} H1 bins at "
                            f"{bb.speed_rad_s / (2 * np.pi):.4g} Hz within {KERNEL_BINS} bins of "
                            "the test band's edges")
        h1 = est.h1[sel]
        sigma = h1_random_error(coh, est.averages) * np.abs(h1)
        dropped = int((inside[:, None] & (coh < MIN_COHERENCE)).sum())
        if dropped:
            left_out.append(f"{name}: {dropped} of {used.size} H1 points at "
                            f"{bb.speed_rad_s / (2 * np.pi):.4g} Hz below coherence "
                            f"{MIN_COHERENCE:g}")
        out.append(BandPoints(bb.speed_rad_s, bb.w_F, actuator, list(bb.outputs),
                              est.freq_hz[sel], h1, sigma, used, kernel=spectral_kernel(est)))
    return out


def target_of(comp: Comparison, name: str) -> Target:
    """The measured points of a comparison (module docstring)."""
    left_out: list[str] = []
    run = comp.run
    speeds, channels, measured, sigma, drift, used = _one_x(comp, name, left_out)
    if run.has_test_force and channels:
        left_out.append(f"{name}: 1x points not used (the test force's response at the "
                        "rotational frequency adds to them)")
        channels = []
    amps = {k: v for k, v in run.scenario.amplitudes.items() if v != 0}
    u_ref = next(iter(amps.values())) if len(amps) == 1 else 1.0
    units = dict(comp.one_x.units) if comp.one_x is not None else {}
    target = Target(name, run.scenario, u_ref, speeds, channels, units, measured, sigma, drift,
                    used,
                    _band(comp, name, left_out), left_out)
    if target.points == 0:
        raise ModelError(f"{name}: no settled 1x point and no coherent H1 bin to fit "
                         "(see the notes of `rotor-avc compare` on it)")
    return target
