"""``index.html`` of ``rotor-avc campbell --out``: the Campbell diagram and the damping of every
mode over speed, interactive (:mod:`rotor_avc.interactive.page`), with the critical speeds
and onsets of instability as tables."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analysis.campbell import CampbellDiagram
from .campbell_plot import COLOUR_BY
from ..interactive.page import Figure, page, table_html
from ..output_files import write_text


def campbell_figures(cd: CampbellDiagram, colour: str, orders, max_freq_hz: float | None):
    label, values = COLOUR_BY[colour]
    s, f, c = cd.speed_hz, cd.freq_hz, values(cd)
    top = max_freq_hz if max_freq_hz is not None else 1.1 * max(orders) * s[-1]
    shown = [k for k in range(f.shape[1]) if f[:, k].min() <= top]
    finite = c[:, shown][np.isfinite(c[:, shown])] if shown else np.zeros(1)
    cmin, cmax = float(min(finite.min(), 0.0)), float(max(finite.max(), 1e-6))
    traces = []
    for k in shown:
        traces.append({"type": "scatter", "mode": "lines+markers", "name": cd.labels[k],
                       "x": s, "y": f[:, k], "customdata": c[:, k],
                       "line": {"color": "rgba(120,120,120,0.5)", "width": 1},
                       "marker": {"size": 5, "color": np.nan_to_num(c[:, k], posinf=cmax),
                                  "colorscale": "Viridis", "cmin": cmin, "cmax": cmax,
                                  "showscale": k == shown[0], "colorbar": {"title": {"text": label}}},
                       "hovertemplate": f"{cd.labels[k]}<br>speed %{{x:.4g}}<br>f %{{y:.4g}} Hz"
                                        f"<br>{label.split(' [')[0]} %{{customdata:.4g}}<extra></extra>"})
    for order in orders:
        traces.append({"type": "scatter", "mode": "lines", "name": f"{order}x", "x": [s[0], s[-1]],
                       "y": [order * s[0], order * s[-1]],
                       "line": {"color": "black", "dash": "dash" if order == 1 else "dot", "width": 1}})
    crit = cd.critical_speeds(orders)
    if crit:
        traces.append({"type": "scatter", "mode": "markers", "name": "critical speeds",
                       "x": [r["speed_hz"] for r in crit], "y": [r["order"] * r["speed_hz"] for r in crit],
                       "text": [f"{r['mode']}, order {r['order']}" for r in crit],
                       "marker": {"symbol": "circle-open", "size": 11, "color": "red"}})
    for r in cd.instability_onsets():
        traces.append({"type": "scatter", "mode": "lines", "name": f"onset of instability ({r['mode']})",
                       "x": [r["speed_hz"], r["speed_hz"]], "y": [0, top],
                       "line": {"color": "red", "width": 2}})
    campbell = Figure("campbell", "damped natural frequencies over speed", traces,
                      y_title="damped natural frequency [Hz]",
                      layout={"yaxis": {"range": [0, top]}}, height_px=560)
    damping = Figure("damping", label.split(" [")[0] + " over speed",
                     [{"type": "scatter", "mode": "lines", "name": cd.labels[k], "x": s, "y": c[:, k]}
                      for k in shown], y_title=label)
    return [campbell, damping]


def write_campbell_html(cd: CampbellDiagram, path: Path, title: str, colour: str, orders,
                        max_freq_hz: float | None, speed_unit: str) -> Path:
    crit = [{**r, "speed_rpm": r["speed_hz"] * 60, "freq_hz": r["order"] * r["speed_hz"]}
            for r in cd.critical_speeds(orders)]
    onsets = [{**r, "speed_rpm": r["speed_hz"] * 60} for r in cd.instability_onsets()]
    fig_campbell, fig_damping = campbell_figures(cd, colour, orders, max_freq_hz)
    blocks = [fig_campbell, "<h2>Critical speeds</h2>",
              table_html(crit, [("mode", "mode"), ("order", "order"), ("speed_hz", "speed [Hz]"),
                                ("speed_rpm", "speed [rpm]"), ("freq_hz", "frequency [Hz]")])
              if crit else "<p>No excitation line meets a mode in the speed range.</p>",
              "<h2>Onset of instability</h2>",
              table_html(onsets, [("mode", "mode"), ("speed_hz", "speed [Hz]"),
                                  ("speed_rpm", "speed [rpm]"), ("freq_hz", "whirl frequency [Hz]")])
              if onsets else "<p>Every mode stays stable over the speed range.</p>",
              fig_damping]
    write_text(path, page(title, blocks, default_speed_unit=speed_unit))
    return path
