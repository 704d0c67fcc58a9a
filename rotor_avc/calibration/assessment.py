"""Before and after: how well a machine model describes a recording's measured points.

Per recording and model (the configured and the calibrated machine):

* ``chi2``: the reduced chi-square of its weighted residual (rotor_avc.calibration.targets);
* the 1x error per dwell and channel, in dB and degrees (``measured / model``);
* FRAC per channel, the frequency response assurance criterion over the measured speeds
  (Heylen, Lammens & Sas, *Modal Analysis Theory and Testing*, 1997):
  ``|sum Y_m^* Y_a|^2 / (sum |Y_m|^2 sum |Y_a|^2)``, 1 for responses of the same shape over speed;
* MAC per dwell (Allemang & Brown 1982) of the measured and the modelled response vectors over
  the channels, each channel divided by its measured RMS over speed so that channels of other
  units count alike: 1 where the deflection shapes agree; at the dwell nearest a resonance the
  shape is that of its mode;
* resonances: the peaks of the model's 1x over a dense speed grid of the measured range per
  channel (rotor_avc.analysis.resonance_peaks), beside the measured peak where the measured
  points resolve it.
"""
from __future__ import annotations

import numpy as np

from ..analysis.resonance_peaks import measured_resonance, model_peaks
from .targets import Target

DENSE_POINTS = 400


def frac(measured: np.ndarray, model: np.ndarray) -> float:
    den = np.sum(np.abs(measured) ** 2) * np.sum(np.abs(model) ** 2)
    return float(np.abs(np.vdot(measured, model)) ** 2 / den) if den > 0 else float("nan")


def mac(a: np.ndarray, b: np.ndarray) -> float:
    return frac(a, b)


def _db(x):
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.abs(x))


def dense_model(target: Target, machine) -> dict:
    """The model's 1x over :data:`DENSE_POINTS` speeds of the measured range:
    ``{"speed_hz": ..., channel: complex values}`` (empty without 1x points)."""
    hz = target.speed_rad_s / (2 * np.pi)
    if not target.channels or hz.size < 2:
        return {}
    dense_hz = np.linspace(float(hz.min()), float(hz.max()), DENSE_POINTS)
    return {"speed_hz": dense_hz, **target.one_x(machine, 2 * np.pi * dense_hz)}


def assess(target: Target, machine, residual: np.ndarray, dof: int, dense: dict) -> dict:
    """The measures of the module docstring for one recording and one machine (``dense`` its
    :func:`dense_model`)."""
    out = {"chi2": float(residual @ residual / max(dof, 1)), "points": target.points}
    if target.band:
        out["frac_h1"] = band_frac(target, machine)
    if not target.channels:
        return out
    speeds = target.speed_rad_s
    model = target.one_x(machine, speeds)
    hz = speeds / (2 * np.pi)
    errors, fracs = [], {}
    for ch in target.channels:
        use = target.used[ch]
        m, a = target.measured[ch], model[ch]
        fracs[ch] = frac(m[use], a[use])
        for k in np.flatnonzero(use):
            errors.append({"channel": ch, "speed_hz": float(hz[k]),
                           "error_db": float(_db(m[k]) - _db(a[k])),
                           "error_deg": float(np.degrees(np.angle(m[k] / a[k])))})
    scale = {ch: np.sqrt(np.mean(np.abs(target.measured[ch][target.used[ch]]) ** 2))
             for ch in target.channels}
    macs = []
    for k in range(speeds.size):
        chans = [ch for ch in target.channels if target.used[ch][k] and scale[ch] > 0]
        if len(chans) >= 2:
            m = np.array([target.measured[ch][k] / scale[ch] for ch in chans])
            a = np.array([model[ch][k] / scale[ch] for ch in chans])
            macs.append({"speed_hz": float(hz[k]), "mac": mac(m, a), "channels": len(chans)})
    out.update({"one_x_error": errors, "frac": fracs, "mac": macs,
                "resonances": resonances(target, dense)})
    return out


def band_frac(target: Target, machine) -> dict[str, float]:
    """FRAC per output over the used H1 bins, all broadband dwells together."""
    _, loops = target.loops(machine)
    measured, model = {}, {}
    for b in target.band:
        H = b.model(loops)
        for i, name in enumerate(b.outputs):
            use = b.used[:, i]
            measured.setdefault(name, []).append(b.h1[use, i])
            model.setdefault(name, []).append(H[use, i])
    return {name: frac(np.concatenate(measured[name]), np.concatenate(model[name]))
            for name in measured}


def resonances(target: Target, dense: dict) -> list[dict]:
    order = np.argsort(target.speed_rad_s)
    hz = target.speed_rad_s[order] / (2 * np.pi)
    if hz.size < 3 or not dense:
        return []
    out = []
    for ch in target.channels:
        for peak in model_peaks(dense["speed_hz"], dense[ch]):
            row = {"channel": ch, "model_hz": float(peak["freq_hz"]),
                   "model_level_db": float(peak["level_db"])}
            use = target.used[ch][order]
            found, why = measured_resonance(hz[use], _db(target.measured[ch][order][use]), peak)
            row.update({"measured_hz": found["freq_hz"], "measured_level_db": found["level_db"]}
                       if found else {"measured_hz": None, "why": why})
            out.append(row)
    return out
