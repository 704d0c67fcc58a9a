"""Interactive figures of a comparison (:class:`rotor_avc.compare.comparison.Comparison`): 1x
magnitude and phase per channel, broadband H1/H2 and coherence per dwell, poles."""
from __future__ import annotations

import numpy as np

from ..interactive.page import Figure

MODEL_DASH = {"sampled": "solid", "continuous": "dash"}


def one_x_figures(comp) -> list[Figure]:
    one = comp.one_x
    f = one.speed_rad_s / (2 * np.pi)
    figs = []
    for ch, meas in one.measured.items():
        def traces(fn):
            out = [{"type": "scatter", "mode": "lines", "name": f"{m} model",
                    "x": one.dense_speed_rad_s[m] / (2 * np.pi), "y": fn(one.dense[m][ch]),
                    "line": {"dash": MODEL_DASH[m], "width": 1.5}} for m in MODEL_DASH]
            return out + [{"type": "scatter", "mode": "markers", "name": "measured 1x", "x": f,
                           "y": fn(meas), "marker": {"size": 8, "symbol": "circle-open"}}]
        figs.append(Figure(f"one-x-{ch}", f"1x response of {ch} ({one.reference})",
                           traces(np.abs), y_title="1x magnitude", unit=one.units[ch],
                           magnitude_key="y", height_px=340))
        figs.append(Figure(f"one-x-phase-{ch}", f"1x phase of {ch}",
                           traces(lambda v: np.degrees(np.angle(v))), y_title="phase [deg]",
                           height_px=260))
    return figs


def broadband_figures(comp) -> list[Figure]:
    figs = []
    for bb in comp.broadband:
        est = bb.estimate
        sel = np.isin(est.freq_hz, bb.models["sampled"].freq_hz)
        f, speed_hz = est.freq_hz[sel], bb.speed_rad_s / (2 * np.pi)
        for i, name in enumerate(bb.outputs):
            traces = [{"type": "scatter", "mode": "lines", "name": "H1", "x": f,
                       "y": np.abs(est.h1[sel, i]), "line": {"color": "black", "width": 1}},
                      {"type": "scatter", "mode": "lines", "name": "H2", "x": f,
                       "y": np.abs(est.h2[sel, i]), "line": {"color": "gray", "width": 1}}]
            traces += [{"type": "scatter", "mode": "lines", "name": f"{m} model", "x": f,
                        "y": np.abs(bb.models[m].responses[name]),
                        "line": {"dash": MODEL_DASH[m], "width": 1.5}} for m in MODEL_DASH]
            tag = f"{name}-{speed_hz:.3f}".replace(".", "_")
            figs.append(Figure(f"broadband-{tag}", f"broadband FRF to {name} at {speed_hz:.3f} Hz",
                               traces, x_title="frequency [Hz]", y_title="|H|",
                               unit=f"{bb.models['sampled'].units[name]}", speed_axis=None,
                               magnitude_key="y", height_px=340))
            figs.append(Figure(f"coherence-{tag}", f"coherence of {name} at {speed_hz:.3f} Hz",
                               [{"type": "scatter", "mode": "lines", "name": "coherence", "x": f,
                                 "y": est.coherence[sel, i]}], x_title="frequency [Hz]",
                               y_title="coherence", speed_axis=None, height_px=240))
    return figs


def poles_figure(comp) -> list[Figure]:
    if not comp.poles:
        return []
    nyquist = 0.5 / comp.run.sample_period_s
    traces = []
    for p in comp.poles:
        for m, symbol in (("continuous", "x"), ("sampled", "circle-open")):
            s = p[m]
            s = s[(s.imag >= 0) & (s.imag / (2 * np.pi) <= nyquist)]
            traces.append({"type": "scatter", "mode": "markers", "name": f"{m} at {p['speed_hz']:.2f} Hz",
                           "x": s.real, "y": s.imag / (2 * np.pi), "marker": {"symbol": symbol, "size": 8}})
    return [Figure("poles", "closed-loop poles with the run's damping", traces,
                   x_title="Re s [1/s]", y_title="Im s / 2 pi [Hz]", speed_axis=None)]
