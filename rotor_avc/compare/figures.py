"""Interactive figures of a comparison (:class:`rotor_avc.compare.comparison.Comparison`): 1x
magnitude and phase per channel, broadband H1/H2 and coherence per dwell, poles."""
from __future__ import annotations

import numpy as np

from ..interactive.page import Figure
from ..interactive.plot_data import sequential_colours
from ..interactive.symlog import symlog, symlog_axis

MODEL_DASH = {"sampled": "solid", "continuous": "dash"}
#: the pole map's symmetric-log axis is linear within about this real part [1/s]
POLE_X0 = 1.0


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
    """The closed-loop poles at the run's speeds (continuous x, sampled-loop o), the real parts
    on a symmetric-log axis (:mod:`rotor_avc.interactive.symlog`, x0 = :data:`POLE_X0`) so that
    lightly damped structural modes and fast controller poles both show; hover: the true s."""
    if not comp.poles:
        return []
    nyquist = 0.5 / comp.run.sample_period_s
    colours = sequential_colours(len(comp.poles))
    traces, reals = [], []
    for p, colour in zip(comp.poles, colours):
        for m, symbol in (("continuous", "x"), ("sampled", "circle-open")):
            s = p[m]
            s = s[(s.imag >= 0) & (s.imag / (2 * np.pi) <= nyquist)]
            reals.append(s.real)
            traces.append({"type": "scatter", "mode": "markers", "name": f"{m} at {p['speed_hz']:.2f} Hz",
                           "x": symlog(s.real, POLE_X0), "y": s.imag / (2 * np.pi),
                           "customdata": s.real, "marker": {"symbol": symbol, "size": 8,
                                                            "color": colour},
                           "hovertemplate": "Re s %{customdata:.5g} 1/s<br>Im s / 2 pi %{y:.5g} Hz"
                                            f"<extra>{m} at {p['speed_hz']:.2f} Hz</extra>"})
    axis = symlog_axis(np.concatenate(reals), POLE_X0, "Re s [1/s]")
    return [Figure("poles", "closed-loop poles with the run's damping (x continuous, o sampled "
                   "loop)", traces, x_title=axis["title"]["text"], y_title="Im s / 2 pi [Hz]",
                   speed_axis=None, layout={"xaxis": axis}, height_px=460)]
