"""``index.html`` of ``rotor-avc runup``: waterfall, 1x Bode and polar plots, orbits, the
API 684 tables and the ISO 20816-3 zones of a recorded run-up, interactive
(:mod:`rotor_avc.interactive.page`)."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from ..compare.report import iso_heading, iso_table
from ..compare.runup_views import OneXTrack, Orbit, Waterfall
from ..analysis.api684 import verdict_line
from ..interactive.page import SPEED_UNIT, Figure, table_html, write_page
from ..interactive.plot_data import colour_scale
from .runup_plots import ORDERS, WATERFALL_RANGE_DB, waterfall_levels

API_COLUMNS = [("speed_hz", "N_c [Hz]"), ("speed_rpm", "N_c [rpm]"), ("peak", "peak"),
               ("amplification_factor", "AF"), ("n1_hz", "N_1 [Hz]"), ("n2_hz", "N_2 [Hz]"),
               ("position", "position"), ("separation_margin_pct", "SM [%]"),
               ("required_margin_pct", "SM required [%]"), ("verdict", "verdict")]
VERDICT_CLASS = {"verdict": lambda v: {"pass": "pass", "fail": "fail"}.get(v, "")}


def waterfall_figure(wf: Waterfall, unit: str) -> Figure:
    """Amplitude spectra over speed in dB re 1 ``unit`` over the top :data:`WATERFALL_RANGE_DB`
    (as ``waterfall.png``: the magnitude selector leaves it in dB), orders marked."""
    top, sel, level, peak = waterfall_levels(wf)
    traces = [{"type": "heatmap", "x": wf.speed_hz, "y": wf.freq_hz[sel], "z": level.T,
               "colorscale": colour_scale("Magma"), "zmin": peak - WATERFALL_RANGE_DB, "zmax": peak,
               "hovertemplate": f"speed %{{x:.4g}} {SPEED_UNIT}<br>f %{{y:.4g}} Hz<br>"
                                "amplitude %{z:.1f} dB<extra></extra>"}]
    traces += [{"type": "scatter", "mode": "lines", "name": f"{k}x", "x": wf.speed_hz,
                "y": k * wf.speed_hz, "line": {"color": "white", "dash": "dash", "width": 1}}
               for k in ORDERS]
    return Figure("waterfall", f"waterfall of {wf.channel} (amplitude spectra over speed, dB)",
                  traces, y_title="frequency [Hz]", z_title=f"dB re 1 {unit}",
                  layout={"yaxis": {"range": [0, top]}, "showlegend": False}, height_px=520)


def bode_figures(track: OneXTrack, channel: str) -> list[Figure]:
    unit = track.units[channel]
    meas, model = track.measured[channel], track.model[channel]
    x = track.speed_hz

    def pair(values_model, values_meas):
        return [{"type": "scatter", "mode": "lines", "name": "model (continuous loop)",
                 "x": track.model_speed_hz, "y": values_model},
                {"type": "scatter", "mode": "markers", "name": "measured 1x", "x": x,
                 "y": values_meas, "marker": {"size": 5}}]

    mag = Figure(f"bode-mag-{channel}", f"1x amplitude of {channel}",
                 pair(np.abs(model), np.abs(meas)), y_title="1x amplitude", unit=unit,
                 magnitude_key="y")
    phase = Figure(f"bode-phase-{channel}", f"1x phase of {channel}",
                   pair(np.degrees(np.angle(model)), np.degrees(np.angle(meas))),
                   y_title="1x phase [deg]", height_px=300)
    def speeds(values):
        return [f"{f:.4g} Hz / {f * 60:.0f} rpm" for f in values]

    polar = Figure(f"polar-{channel}", f"1x polar plot of {channel}",
                   [{"type": "scatter", "mode": "lines", "name": "model (continuous loop)",
                     "x": model.real, "y": model.imag, "text": speeds(track.model_speed_hz)},
                    {"type": "scatter", "mode": "lines+markers", "name": "measured 1x",
                     "x": meas.real, "y": meas.imag, "text": speeds(x), "marker": {"size": 5}}],
                   x_title=f"Re [{unit}]", y_title=f"Im [{unit}]", speed_axis=None,
                   layout={"yaxis": {"scaleanchor": "x"}}, height_px=520)
    return [mag, phase, polar]


def orbit_figure(orbits: list[Orbit]) -> Figure:
    traces = []
    for o in orbits:
        name = f"{o.point} at {o.speed_hz:.4g} Hz ({o.speed_hz * 60:.0f} rpm)"
        traces.append({"type": "scatter", "mode": "lines", "name": name + " raw",
                       "x": o.raw_m[:, 0] * 1e6, "y": o.raw_m[:, 1] * 1e6, "line": {"width": 0.6}})
        traces.append({"type": "scatter", "mode": "lines", "name": name + " 1x",
                       "x": o.one_x_m[:, 0] * 1e6, "y": o.one_x_m[:, 1] * 1e6, "line": {"width": 2}})
    a, b = orbits[0].axes
    return Figure("orbits", "orbits (click legend entries to show or hide)", traces,
                  x_title=f"{a.rpartition('_')[2]} displacement [um]",
                  y_title=f"{b.rpartition('_')[2]} displacement [um]", speed_axis=None,
                  layout={"yaxis": {"scaleanchor": "x"}}, height_px=560)


def api_rows(checks) -> list[dict]:
    return [{**c.row(), "speed_rpm": c.speed_hz * 60} for c in checks]


def write_runup_html(path: Path, title: str, summary: list[tuple[str, str]], notes: list[str],
                     verdict: dict, wf: Waterfall, wf_unit: str, track: OneXTrack,
                     orbits: list[Orbit], tables: dict, operating_hz, speed_unit: str,
                     iso20816=()) -> Path:
    """The page: ``verdict`` the API 684 verdict (:func:`rotor_avc.analysis.api684.
    overall_verdict`, its undetermined rows counted in the line), ``notes`` the run's (windows
    left out among them); ``speed_unit`` the unit it opens with."""
    lo, hi = operating_hz
    css = "fail" if verdict["failed"] else "pass"
    note_items = "".join(f"<li>{html.escape(n)}</li>" for n in notes) or "<li>none</li>"
    blocks = [f'<p class="{css}" style="font-size:20px">{html.escape(verdict_line(verdict))}</p>',
              "<h2>Run</h2>", table_html([{"k": k, "v": v} for k, v in summary],
                                         [("k", "item"), ("v", "value")]),
              f"<h2>Notes</h2><ul>{note_items}</ul>",
              iso_heading(iso20816), iso_table(iso20816),
              "<h2>Waterfall</h2>", waterfall_figure(wf, wf_unit),
              f"<h2>API 684 unbalance-response checks</h2><p class=\"note\">Operating speed range "
              f"{lo:g} .. {hi:g} Hz ({lo * 60:.0f} .. {hi * 60:.0f} rpm). Amplification factor by "
              "the half-power method, AF = N_c / (N_2 - N_1); required separation margin "
              "min(16, 17 (1 - 1/(AF - 1.5))) % below the range, min(26, 10 + 17 (1 - 1/(AF - 1.5))) % "
              "above it, none for AF &lt; 2.5 (API 617 / API 684).</p>"]
    for channel, both in tables.items():
        for kind in ("measured", "model"):
            rows = api_rows(both[kind])
            blocks.append(f"<h3>{html.escape(channel)}, {kind} "
                          f"[{html.escape(track.units[channel])}]</h3>")
            blocks.append(table_html(rows, API_COLUMNS, VERDICT_CLASS) if rows
                          else "<p>No resonance peak in the speed range.</p>")
    blocks.append(f"<h2>1x Bode and polar plots</h2><p class=\"note\">{html.escape(track.method)}; "
                  "model: the continuous loop of the recorded configuration at the same speeds.</p>")
    for channel in track.measured:
        blocks += bode_figures(track, channel)
    if orbits:
        blocks += ["<h2>Orbits</h2>", orbit_figure(orbits)]
    return write_page(path, title, blocks, speed_unit)
