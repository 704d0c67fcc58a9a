"""The acceptance rules of a comparison (rotor_avc.compare.comparison): the tolerances, the
compared 1x and broadband results, the metrics of the 1x response, the checks of the 1x
response and the broadband FRFs (magnitude and phase), dead channels, and the reason for "no
verdict" when nothing could be rated. The tolerances and what a lockstep bag achieves are stated
in rotor_avc.compare.comparison."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..analysis.frf_estimate import FrfEstimate
from ..analysis.resonance_peaks import measured_resonance, model_peaks
from ..analysis.transfer import TransferFrf
from .recorded_run import RecordedRun

TOL_OFF_RESONANCE_DB = 0.5
TOL_AT_RESONANCE_DB = 2.0
TOL_RESONANCE_PCT = 1.0
TOL_BAND_RMS_DB = 0.5
TOL_PHASE_OFF_RESONANCE_DEG = 5.0
TOL_PHASE_AT_RESONANCE_DEG = 15.0
TOL_BAND_PHASE_RMS_DEG = 5.0
#: a channel whose 1x is this far below the model at every checked point is dead
DEAD_DB = 120.0
#: channel prefix of the harmonic controller's forces (rotor_avc.compare.recorded_run)
HARMONIC = "harmonic_"
#: exit status of ``rotor-avc compare`` when nothing could be rated (0 pass, 1 fail)
EXIT_NO_VERDICT = 5
FLOOR_DB = 40.0
MIN_COHERENCE = 0.98
MIN_BROADBAND_SAMPLES = 2048
#: a dwell point whose 1x phasor still changes by more than this (relative) between the two
#: halves of its analysis window is not in steady state: left out of the 1x checks and listed
#: (lightly damped open-loop modes need dwells of many time constants)
SETTLE_TOL = 0.02


@dataclass
class Check:
    """One metric against its tolerance; ``passed`` None: nothing to check, or reported without
    a verdict (the continuous model)."""

    name: str
    value: float | None
    tolerance: float
    unit: str
    passed: bool | None
    detail: str = ""

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclass
class OneX:
    """Measured and modelled 1x phasors (per unit of ``reference``) over speed (rad/s)."""

    method: str
    settings: dict
    reference: str
    units: dict[str, str]
    speed_rad_s: np.ndarray
    measured: dict[str, np.ndarray]
    model: dict[str, dict[str, np.ndarray]]                # model -> channel -> at speed_rad_s
    dense_speed_rad_s: dict[str, np.ndarray]
    dense: dict[str, dict[str, np.ndarray]]
    resonances: list[dict] = field(default_factory=list)
    channels: dict[str, dict] = field(default_factory=dict)  # model -> channel metrics
    #: channel -> relative drift of the 1x phasor within its window (stepped dwells only)
    drift: dict[str, np.ndarray] = field(default_factory=dict)
    #: channel -> standard error of each quadrature component of the measured phasor (from the
    #: residual of its least-squares fit), per unit of ``reference``
    sigma: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class Broadband:
    """H1/H2 from the test force at one dwell, against both transfer models."""

    speed_rad_s: float
    w_F: float
    estimate: FrfEstimate
    outputs: list[str]
    band_hz: tuple[float, float]
    models: dict[str, TransferFrf]
    channels: dict[str, dict] = field(default_factory=dict)


def _db(values) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.abs(values))


def _one_x_metrics(one: OneX) -> None:
    """Errors per channel and point. With the harmonic controller's forces driving the model,
    its dense curve (the feedback loop alone) does not describe the run: the floor is taken
    from the model at the measured points and no resonance is looked for."""
    f_meas = one.speed_rad_s / (2 * np.pi)
    driven = any(ch.startswith(HARMONIC) for ch in one.measured)
    for m in one.model:
        f_dense = one.dense_speed_rad_s[m] / (2 * np.pi)
        one.channels[m] = {}
        for ch, meas in one.measured.items():
            if ch.startswith(HARMONIC):
                one.channels[m][ch] = {"skipped": "an input: the harmonic controller's force, "
                                                  "whose measured 1x drives the model"}
                continue
            dense, mod = one.dense[m][ch], one.model[m][ch]
            peak = float(np.abs(mod if driven else dense).max())
            if peak == 0.0 or not np.all(np.isfinite(dense)):
                one.channels[m][ch] = {"skipped": "the model's response is zero"}
                continue
            valid = np.abs(mod) >= peak * 10 ** (-FLOOR_DB / 20)
            unsettled = one.drift[ch] > SETTLE_TOL if ch in one.drift else np.zeros_like(valid)
            dead = bool(valid.any()) and bool(
                np.all(np.abs(meas[valid]) <= np.abs(mod[valid]) * 10 ** (-DEAD_DB / 20)))
            valid &= ~unsettled & (not dead)
            peaks = [] if dead or driven else [p for p in model_peaks(f_dense, dense)
                                               if f_meas.min() <= p["freq_hz"] <= f_meas.max()]
            at = np.zeros(f_meas.shape, bool)
            for p in peaks:
                at |= (f_meas >= p["band_hz"][0]) & (f_meas <= p["band_hz"][1])
                found, why = measured_resonance(f_meas, _db(meas), p)
                row = {"model": m, "channel": ch, "model_hz": p["freq_hz"],
                       "model_level_db": p["level_db"], "half_power_band_hz": list(p["band_hz"])}
                if found:
                    row.update(measured_hz=found["freq_hz"], measured_level_db=found["level_db"],
                               freq_error_pct=100 * (found["freq_hz"] / p["freq_hz"] - 1),
                               level_error_db=found["level_db"] - p["level_db"])
                else:
                    row["not_resolved"] = why
                one.resonances.append(row)
            with np.errstate(divide="ignore", invalid="ignore"):
                err = _db(meas) - _db(mod)
                phase = np.degrees(np.angle(meas / mod))
            err = np.where(valid, err, np.nan)
            one.channels[m][ch] = {
                "error_db": err, "phase_error_deg": np.where(valid, phase, np.nan),
                "at_resonance": at, "checked_points": int(valid.sum()),
                "unsettled": unsettled, "dead": dead,
                "band_rms_db": float(np.sqrt(np.nanmean(err ** 2))) if valid.any() else None}


def _worst(items, what: str):
    """(value, detail) of the largest |value| among (value, description) pairs (an infinite
    value counts: it fails; NaN and None mean nothing to rate)."""
    items = [(abs(v), d) for v, d in items if v is not None and not np.isnan(v)]
    if not items:
        return None, f"no {what}"
    v, d = max(items, key=lambda x: x[0])
    return float(v), f"worst: {d}"


def _one_x_checks(one: OneX, m: str) -> list[Check]:
    f = one.speed_rad_s / (2 * np.pi)
    off, at, rms, ph_off, ph_at = [], [], [], [], []
    for ch, c in one.channels[m].items():
        if "skipped" in c:
            continue
        for k in np.flatnonzero(~np.isnan(c["error_db"])):
            where = f"{ch} at {f[k]:.3f} Hz"
            (at if c["at_resonance"][k] else off).append((c["error_db"][k], where))
            (ph_at if c["at_resonance"][k] else ph_off).append((c["phase_error_deg"][k], where))
        rms.append((c["band_rms_db"], ch))
    res = [r for r in one.resonances if r["model"] == m and "measured_hz" in r]
    specs = [("1x magnitude error away from resonances", off, TOL_OFF_RESONANCE_DB, "dB",
              "points"),
             ("1x magnitude error at resonances", at, TOL_AT_RESONANCE_DB, "dB",
              "points at a resonance"),
             ("1x phase error away from resonances", ph_off, TOL_PHASE_OFF_RESONANCE_DEG,
              "deg", "points"),
             ("1x phase error at resonances", ph_at, TOL_PHASE_AT_RESONANCE_DEG, "deg",
              "points at a resonance"),
             ("1x band RMS error", rms, TOL_BAND_RMS_DB, "dB", "channels"),
             ("resonance frequency error", [(r["freq_error_pct"], f"{r['channel']} at "
                                             f"{r['model_hz']:.3f} Hz") for r in res],
              TOL_RESONANCE_PCT, "%", "resolved resonances"),
             ("resonance peak level error", [(r["level_error_db"], f"{r['channel']} at "
                                              f"{r['model_hz']:.3f} Hz") for r in res],
              TOL_AT_RESONANCE_DB, "dB", "resolved resonances")]
    out = []
    for name, items, tol, unit, what in specs:
        value, detail = _worst(items, what)
        out.append(Check(name, value, tol, unit, None if value is None else value <= tol,
                         detail))
    left_out = [(100 * one.drift[ch][k], f"{ch} at {f[k]:.3f} Hz")
                for ch, c in one.channels[m].items() if "unsettled" in c
                for k in np.flatnonzero(c["unsettled"])]
    if left_out:
        value, detail = _worst(left_out, "points")
        out.append(Check(f"1x points not in steady state, left out ({len(left_out)})", value,
                         100 * SETTLE_TOL, "% drift", None,
                         detail + " -- the 1x phasor still changed within the dwell; dwell "
                                  "longer to check these"))
    return out


# -- broadband ------------------------------------------------------------------------------------
def _broadband_checks(bbs: list[Broadband], m: str) -> list[Check]:
    out = []
    for bb in bbs:
        at = f"at {bb.speed_rad_s / (2 * np.pi):.3f} Hz"
        for name, key, tol, unit in (("band RMS error", "band_rms_db", TOL_BAND_RMS_DB, "dB"),
                                     ("phase RMS error", "phase_rms_deg", TOL_BAND_PHASE_RMS_DEG,
                                      "deg")):
            value, detail = _worst([(c[key], ch) for ch, c in bb.channels[m].items()],
                                   f"bins with coherence >= {MIN_COHERENCE}")
            out.append(Check(f"broadband H1 {name} {at}", value, tol, unit,
                             None if value is None else value <= tol, detail))
    return out


def _dead_channels(one: OneX | None, bbs: list[Broadband], m: str) -> Check | None:
    """The channels that recorded nothing where the model responds (None: none)."""
    dead = set()
    if one is not None:
        dead |= {ch for ch, c in one.channels[m].items() if c.get("dead")}
    for bb in bbs:
        dead |= {ch for ch, c in bb.channels[m].items() if c["dead"]}
    if not dead:
        return None
    return Check("dead channels", float(len(dead)), 0.0, "channels", False,
                 "no response recorded where the model has one: " + ", ".join(sorted(dead))
                 + " -- check the sensor, its wiring and its topic")


def _no_verdict_reason(run: RecordedRun, one: OneX | None, bbs: list[Broadband],
                       dead: Check | None) -> str:
    """Why nothing could be rated."""
    if dead is not None:
        return f"every channel with a response is dead ({dead.detail.split(': ', 1)[1]})"
    if one is None and not bbs:
        return ("nothing to compare: no 1x response (see the notes) and no broadband dwell of a "
                "test force")
    if run.has_test_force and not bbs:
        return ("the test force's dwells give no broadband estimate (see the notes: too short, "
                "or too gapped for the Welch segments) and its response makes the 1x unrated")
    if one is not None:
        ch = one.channels["sampled"]
        unsettled = sum(int(c["unsettled"].sum()) for c in ch.values() if "unsettled" in c)
        if unsettled:
            return (f"every 1x point is left out: {unsettled} point(s) not in steady state, the "
                    f"others more than {FLOOR_DB:g} dB below the model's peak; dwell longer")
        return (f"every 1x point is more than {FLOOR_DB:g} dB below its channel's model peak or "
                "unrated (a run with a test force)")
    return f"no broadband bin reaches coherence {MIN_COHERENCE}"


# -- poles ----------------------------------------------------------------------------------------
