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

Each point's standard uncertainty is ``hypot(sigma, drift |Y|, floor |Y|)``: the random error;
for a dwell, the relative change of the phasor between the two halves of its window (a transient
not yet decayed biases the estimate by about that much, which no noise model shows); and a
relative floor for what no averaging removes (sensor and amplifier calibration, typically 0.5 to
1 % for accelerometers calibrated to ISO 16063-21), so that an almost noise-free channel does not
outweigh all others. The weighted residual of a point is ``(measured - model) / u`` split into its
real and imaginary parts.

The model of a point is the sampled closed loop (what the comparison rates) of the machine
being fitted, in the recording's scenario (sample rate, damping rule, unbalance, test force):
``sum_j G_j(Omega) u_j / u_ref`` for the 1x points, the transfer from the test force for H1.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..analysis.frf_estimate import h1_random_error
from ..analysis.transfer import sampled_transfer_frf
from ..compare.checks import HARMONIC, MIN_COHERENCE, SETTLE_TOL
from ..compare.comparison import Comparison, model_loops, unbalance_models
from ..errors import ModelError

#: default relative uncertainty floor of a measured point
DEFAULT_FLOOR = 0.005


@dataclass
class BandPoints:
    """The coherent H1 bins of one broadband dwell."""

    speed_rad_s: float
    w_F: float
    actuator: str
    outputs: list[str]
    freq_hz: np.ndarray
    h1: np.ndarray                   # (bins, outputs)
    sigma: np.ndarray                # (bins, outputs), absolute
    used: np.ndarray                 # (bins, outputs) bool


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

    def measured_vector(self, floor: float) -> tuple[np.ndarray, np.ndarray]:
        """``(measured, uncertainty)`` of every used point, in :meth:`predicted`'s order."""
        y, s = [], []
        for ch in self.channels:
            use = self.used[ch]
            y.append(self.measured[ch][use])
            relative = np.hypot(self.drift[ch][use], floor)
            s.append(np.hypot(self.sigma[ch][use], relative * np.abs(self.measured[ch][use])))
        for b in self.band:
            y.append(b.h1.T[b.used.T])
            s.append(np.hypot(b.sigma.T[b.used.T], floor * np.abs(b.h1.T[b.used.T])))
        return np.concatenate(y) if y else np.zeros(0, complex), (np.concatenate(s) if s
                                                                 else np.zeros(0))

    def point_channels(self) -> list[str]:
        """The channel of every used point, in :meth:`predicted`'s order (H1: ``name (H1)``)."""
        out = [ch for ch in self.channels for _ in range(int(self.used[ch].sum()))]
        for b in self.band:
            out += [f"{o} (H1)" for i, o in enumerate(b.outputs) for _ in range(int(b.used[:, i].sum()))]
        return out

    def loop(self, machine) -> tuple:
        """``(scenario, sampled loop)`` of ``machine`` in this recording's scenario."""
        scenario = dataclasses.replace(self.scenario, machine=machine)
        return scenario, model_loops(scenario, ("sampled",))

    def one_x(self, machine, speed_rad_s) -> dict[str, np.ndarray]:
        """The sampled-loop model's 1x of every channel at ``speed_rad_s`` (per ``u_ref``)."""
        scenario, loop = self.loop(machine)
        return unbalance_models(scenario, loop, speed_rad_s, self.u_ref,
                                self.channels)["sampled"]

    def predicted(self, machine) -> np.ndarray:
        """The sampled-loop model of every used point for ``machine`` (module docstring)."""
        scenario, loop = self.loop(machine)
        out = []
        if self.channels:
            model = unbalance_models(scenario, loop, self.speed_rad_s, self.u_ref,
                                     self.channels)["sampled"]
            out += [model[ch][self.used[ch]] for ch in self.channels]
        for b in self.band:
            frf = sampled_transfer_frf(loop["sampled"], b.speed_rad_s, b.freq_hz, b.actuator,
                                       b.outputs, b.w_F)
            H = np.column_stack([frf.responses[o] for o in b.outputs])
            out.append(H.T[b.used.T])
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


def _band(comp: Comparison, name: str, left_out: list[str]) -> list[BandPoints]:
    out = []
    actuator = comp.run.scenario.test_force.actuator if comp.broadband else ""
    for bb in comp.broadband:
        est, (lo, hi) = bb.estimate, bb.band_hz
        sel = (est.freq_hz >= max(lo, est.resolution_hz)) & (est.freq_hz <= hi)
        coh = est.coherence[sel]
        used = coh >= MIN_COHERENCE
        h1 = est.h1[sel]
        sigma = h1_random_error(coh, est.averages) * np.abs(h1)
        dropped = int((~used).sum())
        if dropped:
            left_out.append(f"{name}: {dropped} of {used.size} H1 bins at "
                            f"{bb.speed_rad_s / (2 * np.pi):.4g} Hz below coherence "
                            f"{MIN_COHERENCE:g}")
        out.append(BandPoints(bb.speed_rad_s, bb.w_F, actuator, list(bb.outputs),
                              est.freq_hz[sel], h1, sigma, used))
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
