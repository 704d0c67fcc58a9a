"""``index.html`` of ``rotor-avc calibrate``: the fitted parameters with their intervals and
identifiability, the residual and the compare verdicts before and after (fitted and held-out
recordings), per recording and channel the measured 1x over speed against the configured and
the calibrated model (magnitude and phase), the MAC per dwell, and the sensitivity and
correlation matrices -- interactive (:mod:`rotor_avc.interactive.page`)."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from ..calibration.session import Calibration
from ..interactive.page import Figure, table_html, write_page

MODELS = {"configured": "#888888", "calibrated": "#1f77b4"}


def _parameters(doc: dict) -> str:
    rows = []
    for p in doc["parameters"]:
        ci = p["ci95"]
        rows.append({**p, "ci": "-" if ci is None else f"[{ci[0]:.5g}, {ci[1]:.5g}]",
                     "identifiable": "yes" if p["identifiable"] else "no"})
    return table_html(rows, [("path", "parameter"), ("unit", "unit"), ("initial", "configured"),
                             ("value", "calibrated"), ("std", "std"), ("ci", "95 % interval"),
                             ("identifiable", "identifiable"), ("reason", "why not")],
                      {"identifiable": lambda v: "pass" if v == "yes" else "fail"})


def _recordings(rows: list[dict], kind: str) -> list[dict]:
    out = []
    for r in rows:
        out.append({"data": r["data"], "kind": kind, "points": r["points"],
                    "chi2_before": r["configured"]["chi2"], "chi2_after": r["calibrated"]["chi2"],
                    "verdict_before": r["configured"].get("verdict"),
                    "verdict_after": r["calibrated"].get("verdict")})
    return out


def _verdict_class(v) -> str:
    return {"PASS": "pass", "FAIL": "fail"}.get(v, "")


def _overlays(curve: dict) -> list:
    target = curve["target"]
    hz = target.speed_rad_s / (2 * np.pi)
    blocks = []
    for ch in target.channels:
        use = target.used[ch]
        y = target.measured[ch]
        unit = target.units.get(ch, "")
        for part, fn, title, key in (("mag", np.abs, "1x magnitude", "y"),
                                     ("phase", lambda v: np.degrees(np.angle(v)), "1x phase", None)):
            traces = [{"type": "scatter", "mode": "markers", "name": "measured",
                       "x": hz[use], "y": fn(y[use]), "marker": {"color": "#d62728", "size": 8}}]
            if (~use).any():
                traces.append({"type": "scatter", "mode": "markers", "name": "left out",
                               "x": hz[~use], "y": fn(y[~use]),
                               "marker": {"color": "#d62728", "symbol": "x-open", "size": 8}})
            for label, color in MODELS.items():
                dense = curve["models"].get(label)
                if dense:
                    traces.append({"type": "scatter", "mode": "lines", "name": f"{label} model",
                                   "x": dense["speed_hz"], "y": fn(dense[ch]),
                                   "line": {"color": color}})
            blocks.append(Figure(f"{curve['data']}-{ch}-{part}".replace("/", "_"),
                                 f"{curve['data']}: {ch}, {title}", traces,
                                 y_title=title if key else "phase [deg]",
                                 unit=unit if key else "", magnitude_key=key, height_px=320))
    return blocks


def _band_overlays(curve: dict) -> list:
    """Per broadband dwell (or measured FRF set) and output: H1 against both models."""
    blocks = []
    for k, b in enumerate(curve["target"].band):
        where = f"{b.speed_rad_s / (2 * np.pi):.4g} Hz shaft speed, force at {b.actuator}"
        for i, name in enumerate(b.outputs):
            use = b.used[:, i]
            for part, fn, title, key in (("mag", np.abs, "H1 magnitude", "y"),
                                         ("phase", lambda v: np.degrees(np.angle(v)), "H1 phase",
                                          None)):
                traces = [{"type": "scatter", "mode": "markers", "name": "measured",
                           "x": b.freq_hz[use], "y": fn(b.h1[use, i]),
                           "marker": {"color": "#d62728", "size": 5}}]
                for label, color in MODELS.items():
                    H = curve["band"][label][k]
                    traces.append({"type": "scatter", "mode": "lines", "name": f"{label} model",
                                   "x": b.freq_hz, "y": fn(H[:, i]), "line": {"color": color}})
                blocks.append(Figure(f"{curve['data']}-h{k}-{name}-{part}".replace("/", "_"),
                                     f"{curve['data']}: {name} per force, {title} ({where})",
                                     traces, x_title="frequency [Hz]", speed_axis=None,
                                     y_title=title if key else "phase [deg]",
                                     unit="" if key is None else "SI/N", magnitude_key=key,
                                     height_px=320))
    return blocks


def _mac_figure(rows: list[dict]) -> Figure:
    traces = []
    for r in rows:
        for label, color in MODELS.items():
            macs = r[label].get("mac", [])
            traces.append({"type": "scatter", "mode": "lines+markers",
                           "name": f"{r['data']}: {label}", "x": [m["speed_hz"] for m in macs],
                           "y": [m["mac"] for m in macs], "line": {"color": color}})
    return Figure("mac", "MAC of the measured and modelled deflection shapes per dwell", traces,
                  y_title="MAC", height_px=340)


def _matrix(fig_id: str, title: str, z, x, y, zmin=None, zmax=None) -> Figure:
    trace = {"type": "heatmap", "z": z, "x": x, "y": y, "colorscale": "RdBu", "reversescale": True}
    if zmin is not None:
        trace.update({"zmin": zmin, "zmax": zmax})
    return Figure(fig_id, title, [trace], x_title="parameter", speed_axis=None,
                  layout={"yaxis": {"automargin": True}, "xaxis": {"automargin": True}},
                  height_px=max(300, 28 * len(y) + 160))


def sensitivity_by_channel(cal: Calibration, channels: list[str]) -> np.ndarray:
    """Per point channel and parameter: the RMS over that channel's points of the change of
    the weighted residual per 100 % change of the parameter (at the configured values)."""
    J = cal.fit.jacobian
    m = len(channels)
    out = np.zeros((len(set(channels)), J.shape[1]))
    names = list(dict.fromkeys(channels))
    for i, name in enumerate(names):
        rows = [k for k, c in enumerate(channels) if c == name]
        block = np.concatenate([J[rows], J[[m + k for k in rows]]])
        out[i] = np.sqrt(np.mean(block ** 2, axis=0))
    return out


def write_calibration_html(cal: Calibration, doc: dict, path: Path, point_channels) -> Path:
    labels = [p.label for p in cal.params]
    rec_rows = _recordings(doc["data"], "fitted") + _recordings(doc["validation"], "held out")
    res = doc["residual"]
    blocks = [
        "<h2>Parameters</h2>", _parameters(doc),
        f"<p>Reduced chi-square of the weighted residual: {res['before']:.4g} configured, "
        f"{res['after']:.4g} calibrated ({res['dof']} degrees of freedom; sensor calibration "
        f"uncertainty {res['sensor_uncertainty']:g}, one complex gain per channel). Intervals: Student's t on the covariance at the "
        "optimum, scaled by the reduced chi-square where it exceeds 1.</p>",
        "<h2>Recordings: before and after</h2>",
        table_html(rec_rows, [("data", "recording"), ("kind", "used"), ("points", "points"),
                              ("chi2_before", "chi2 configured"), ("chi2_after", "chi2 calibrated"),
                              ("verdict_before", "compare configured"),
                              ("verdict_after", "compare calibrated")],
                   {"verdict_before": _verdict_class, "verdict_after": _verdict_class}),
    ]
    blocks.append("<h3>Points left out</h3><ul>" + ("".join(
        f"<li>{html.escape(x)}</li>" for x in doc["left_out"])
        or "<li>none: every measured point of every recording is used</li>") + "</ul>")
    all_rows = doc["data"] + doc["validation"]
    if any(r["configured"].get("mac") for r in all_rows):
        blocks.append(_mac_figure([r for r in all_rows if r["configured"].get("mac")]))
    names = list(dict.fromkeys(point_channels))
    if cal.fit.jacobian is not None and names:
        S = sensitivity_by_channel(cal, point_channels)
        blocks += ["<h2>Sensitivity and correlation</h2>",
                   _matrix("sensitivity", "sensitivity: weighted residual change per 100 % "
                           "change (RMS over each channel's points, at the configured values)",
                           S, labels, names)]
    corr = np.asarray(cal.fit.correlation, float)
    if np.isfinite(corr).any():
        blocks.append(_matrix("correlation", "correlation of the fitted parameters",
                              np.where(np.isfinite(corr), corr, None).tolist(), labels, labels,
                              -1.0, 1.0))
    blocks.append("<h2>Measured against the configured and the calibrated model</h2>")
    for curve in cal.curves:
        blocks += _overlays(curve) + _band_overlays(curve)
    return write_page(path, f"Calibration of {cal.config_path.name}", blocks)
