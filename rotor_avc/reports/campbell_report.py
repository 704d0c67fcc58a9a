"""``index.html`` of ``rotor-avc campbell --out``: the Campbell diagram and the damping of every
mode over speed, interactive (:mod:`rotor_avc.interactive.page`), with the critical speeds
and onsets of instability as tables, and one view per mode of interest: its shape at the
reference speed (bars of ``|q_i|`` with the phase on hover) and the deflection
``Re(q_i e^{j phi})`` over one period (a phase slider)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analysis.campbell import CampbellDiagram
from ..analysis.mode_shapes import dominant_parts, shape_rows
from .campbell_plot import COLOUR_BY, WHIRL_STYLE, frequency_top, order_line
from ..interactive.page import SPEED_UNIT, Figure, table_html, write_page


#: phase steps of the deflection slider over one period
PHASE_STEPS_DEG = np.arange(0, 360, 15)


def campbell_figures(cd: CampbellDiagram, colour: str, orders, max_freq_hz: float | None,
                     ref: int):
    label, values = COLOUR_BY[colour]
    s, f, c = cd.speed_hz, cd.freq_hz, values(cd)
    top = frequency_top(cd, max_freq_hz)
    shown = [k for k in range(f.shape[1]) if 0 < f[:, k].min() <= top]
    whirl = cd.whirl(ref)
    finite = c[:, shown][np.isfinite(c[:, shown])] if shown else np.zeros(1)
    cmin, cmax = float(min(finite.min(), 0.0)), float(max(finite.max(), 1e-6))
    traces = []
    for k in shown:
        traces.append({"type": "scatter", "mode": "lines+markers", "name": cd.caption(k, ref),
                       "x": s, "y": f[:, k], "customdata": c[:, k],
                       "line": {"color": "rgba(120,120,120,0.5)", "width": 1,
                                "dash": WHIRL_STYLE[whirl[k]][1]},
                       "marker": {"size": 5, "color": np.nan_to_num(c[:, k], posinf=cmax),
                                  "colorscale": "Viridis", "cmin": cmin, "cmax": cmax,
                                  "showscale": k == shown[0],
                                  "colorbar": {"title": {"text": label, "side": "right"},
                                               "x": 1.0, "xanchor": "left", "thickness": 14}},
                       "hovertemplate": f"{cd.caption(k, ref)}<br>speed %{{x:.4g}} {SPEED_UNIT}<br>f %{{y:.4g}} Hz"
                                        f"<br>{label.split(' [')[0]} %{{customdata:.4g}}<extra></extra>"})
    for order in orders:
        xs, ys = order_line(cd, order, top)
        traces.append({"type": "scatter", "mode": "lines", "name": f"{order}x", "x": xs, "y": ys,
                       "line": {"color": "black", "dash": "dash" if order == 1 else "dot", "width": 1}})
    crit = [r for r in cd.critical_speeds(orders) if r["order"] * r["speed_hz"] <= top]
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
                      layout={"yaxis": {"range": [0, top]}, "legend": {"x": 1.14}},
                      height_px=560)
    damping = Figure("damping", label.split(" [")[0] + " over speed",
                     [{"type": "scatter", "mode": "lines", "name": cd.labels[k], "x": s, "y": c[:, k]}
                      for k in shown], y_title=label)
    return [campbell, damping], shown


def shape_figure(cd: CampbellDiagram, k: int, ref: int) -> Figure:
    """Mode ``k`` at speed ``ref``: bars of ``|q_i|`` (normalised) and of the deflection
    ``Re(q_i e^{j phi})`` with a slider over the phase ``phi`` (one period of the motion)."""
    rows = shape_rows(cd.shapes[ref, :, k], cd.geometry.coords)
    names = [r["coordinate"] for r in rows]
    q = np.array([r["magnitude"] * np.exp(1j * np.radians(r["phase_deg"])) for r in rows])
    traces = [{"type": "bar", "name": "|q| (normalised)", "x": names, "y": np.abs(q),
               "customdata": np.angle(q, deg=True), "marker": {"color": "rgba(150,150,150,0.45)"},
               "hovertemplate": "%{x}<br>|q| %{y:.3f}<br>phase %{customdata:.1f} deg"
                                "<extra></extra>"},
              {"type": "bar", "name": "deflection Re(q e^{j phi})", "x": names, "y": q.real,
               "marker": {"color": "steelblue"}}]
    steps = [{"method": "restyle", "label": f"{phi:g}",
              "args": [{"y": [(q * np.exp(1j * np.radians(phi))).real.tolist()]}, [1]]}
             for phi in PHASE_STEPS_DEG]
    title = (f"{cd.caption(k, ref)} (rotor speed {cd.speed_hz[ref]:.4g} Hz, f = "
             f"{cd.freq_hz[ref, k]:.4g} Hz): {dominant_parts(cd.shapes[ref, :, k], cd.geometry)}")
    return Figure(f"shape{k}", title, traces, x_title="generalised coordinate",
                  y_title="normalised amplitude", speed_axis=None,
                  layout={"barmode": "overlay", "yaxis": {"range": [-1.05, 1.05]},
                          "sliders": [{"active": 0, "steps": steps, "y": -0.25,
                                       "currentvalue": {"prefix": "phase [deg] "}}],
                          "margin": {"b": 120}},
                  height_px=380)


def write_campbell_html(cd: CampbellDiagram, path: Path, title: str, colour: str, orders,
                        max_freq_hz: float | None, speed_unit: str,
                        reference_speed_hz: float | None = None) -> Path:
    crit = [{**r, "speed_rpm": r["speed_hz"] * 60, "freq_hz": r["order"] * r["speed_hz"]}
            for r in cd.critical_speeds(orders)]
    onsets = [{**r, "speed_rpm": r["speed_hz"] * 60} for r in cd.instability_onsets()]
    ref = cd.reference_index(reference_speed_hz)
    (fig_campbell, fig_damping), shown = campbell_figures(cd, colour, orders, max_freq_hz, ref)
    blocks = ["<h2>Campbell diagram</h2>", fig_campbell, "<h2>Critical speeds</h2>",
              table_html(crit, [("mode", "mode"), ("order", "order"), ("speed_hz", "speed [Hz]"),
                                ("speed_rpm", "speed [rpm]"), ("freq_hz", "frequency [Hz]")])
              if crit else "<p>No excitation line meets a mode in the speed range.</p>",
              "<h2>Onset of instability</h2>",
              table_html(onsets, [("mode", "mode"), ("speed_hz", "speed [Hz]"),
                                  ("speed_rpm", "speed [rpm]"), ("freq_hz", "whirl frequency [Hz]")])
              if onsets else "<p>Every mode stays stable over the speed range.</p>",
              "<h2>Damping over speed</h2>", fig_damping,
              f"<h2>Mode shapes at {cd.speed_hz[ref]:.4g} Hz</h2><p class=\"note\">generalised "
              "coordinates in their own units (m, rad), normalised to the largest; phases "
              "relative to it; the slider turns the motion through one period. Damping: "
              f"{cd.damping_rule}.</p>"]
    blocks += [shape_figure(cd, k, ref) for k in shown]
    return write_page(path, title, blocks, speed_unit)
