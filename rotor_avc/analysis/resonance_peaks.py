"""Resonance peaks of a response over speed (or frequency): from a dense model curve, and from a
few measured points around one (rotor_avc.compare.comparison).

* :func:`model_peaks` -- peaks of at least :data:`PROMINENCE_DB` dB prominence of a dense curve,
  refined by the parabola (dB over frequency) through the highest grid point and its neighbours,
  with the half-power (-3 dB) band around each;
* :func:`measured_resonance` -- the vertex of the parabola through the highest measured point
  inside a model peak's half-power band and its two neighbours, when they bracket the model's
  peak and span at most half that band (otherwise the reason it is not resolved). The vertex
  errs by a fraction of the spacing that shrinks with (spacing / band)^2: for a single mode of
  4 % damping, points a quarter band apart land within 0.05 % of the peak.
"""
from __future__ import annotations

import numpy as np
import scipy.signal

PROMINENCE_DB = 3.0


def model_peaks(speed_hz: np.ndarray, values: np.ndarray) -> list[dict]:
    """Peaks (prominence >= PROMINENCE_DB) of a dense curve: parabolic vertex in dB and the
    half-power band around it."""
    with np.errstate(divide="ignore"):
        db = 20 * np.log10(np.abs(values))
    if not np.all(np.isfinite(db)):
        return []
    peaks = []
    for i in scipy.signal.find_peaks(db, prominence=PROMINENCE_DB)[0]:
        f, level = parabolic_vertex(speed_hz[i - 1:i + 2], db[i - 1:i + 2])
        lo, hi = i, i
        while lo > 0 and db[lo - 1] >= db[i] - 3.0:
            lo -= 1
        while hi < db.size - 1 and db[hi + 1] >= db[i] - 3.0:
            hi += 1
        peaks.append({"freq_hz": f, "level_db": level, "band_hz": (speed_hz[lo], speed_hz[hi])})
    return peaks


def parabolic_vertex(x, y) -> tuple[float, float]:
    """``(x, y)`` of the vertex of the parabola through three points (the middle point itself
    when they do not curve downwards)."""
    a, b, c = np.polyfit(x - x[1], y, 2)
    if a >= 0:
        return float(x[1]), float(y[1])
    dx = -b / (2 * a)
    return float(x[1] + dx), float(c - b * b / (4 * a))


def measured_resonance(speed_hz, db, peak) -> tuple[dict | None, str]:
    """``({freq_hz, level_db}, "")`` of the measured points (ascending ``speed_hz``, levels
    ``db``) around a :func:`model_peaks` entry, or ``(None, reason)`` when they do not resolve
    it (module docstring)."""
    lo, hi = peak["band_hz"]
    inside = np.flatnonzero((speed_hz >= lo) & (speed_hz <= hi))
    if inside.size == 0:
        return None, "no measured speed inside the half-power band"
    i = int(inside[np.argmax(db[inside])])
    if i == 0 or i == speed_hz.size - 1 or not (db[i] >= db[i - 1] and db[i] >= db[i + 1]):
        return None, "the highest measured point is not bracketed by lower ones"
    if not speed_hz[i - 1] <= peak["freq_hz"] <= speed_hz[i + 1]:
        return None, "the measured points around the maximum do not bracket the model's peak"
    if speed_hz[i + 1] - speed_hz[i - 1] > 0.5 * (hi - lo):
        span = speed_hz[i + 1] - speed_hz[i - 1]
        return None, (f"the measured speeds around the peak span {span:.3g} Hz, more than half "
                      f"its half-power band {hi - lo:.3g} Hz")
    f, level = parabolic_vertex(speed_hz[i - 1:i + 2], db[i - 1:i + 2])
    return {"freq_hz": f, "level_db": level}, ""
