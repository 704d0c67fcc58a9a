"""``index.html`` of ``rotor-avc stability --vary/--study``: the threshold of stability (and the
whirl frequency) over one parameter, or a map over two, interactive
(:mod:`rotor_avc.interactive.page`: the threshold is a rotor speed, drawn in the page's speed
unit)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analysis.stability_study import StudyResult
from ..interactive.page import SPEED_UNIT, Figure, table_html, write_page


def write_stability_study_html(study: StudyResult, path: Path, title: str) -> Path:
    rows = study.rows()
    threshold_hz = np.asarray(study.threshold_rpm, float) / 60.0
    if len(study.varies) == 1:
        v = study.varies[0]
        figs = [Figure("threshold", "threshold of stability", [
                    {"type": "scatter", "mode": "lines+markers", "name": "threshold",
                     "x": v.values, "y": threshold_hz}],
                       x_title=v.label, y_title="threshold", speed_axis="y"),
                Figure("whirl", "whirl frequency at the threshold", [
                    {"type": "scatter", "mode": "lines+markers", "name": "whirl",
                     "x": v.values, "y": study.whirl_rad_s}],
                       x_title=v.label, y_title="whirl frequency [rad/s]", speed_axis=None)]
    else:
        vx, vy = study.varies
        figs = [Figure("threshold", "threshold of stability (blank: none found)", [
                    {"type": "heatmap", "x": vx.values, "y": vy.values, "z": threshold_hz.T,
                     "colorscale": "Viridis",
                     "hovertemplate": f"{vx.label} %{{x:.4g}}<br>{vy.label} %{{y:.4g}}"
                                      f"<br>threshold %{{z:.5g}} {SPEED_UNIT}<extra></extra>"}],
                       x_title=vx.label, y_title=vy.label, z_title="threshold", speed_axis="z",
                       height_px=560)]
    columns = [(k, k) for k in rows[0]]
    return write_page(path, title, [*figs, "<h2>Points</h2>", table_html(rows, columns)])
