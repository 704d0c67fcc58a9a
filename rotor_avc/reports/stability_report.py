"""``index.html`` of ``rotor-avc stability --vary/--study``: the threshold of stability (and the
whirl frequency) over one parameter, or a map over two, interactive
(:mod:`rotor_avc.interactive.page`)."""
from __future__ import annotations

from pathlib import Path

from ..analysis.stability_study import StudyResult
from ..interactive.page import Figure, page, table_html
from ..output_files import write_text


def write_stability_study_html(study: StudyResult, path: Path, title: str) -> Path:
    rows = study.rows()
    if len(study.varies) == 1:
        v = study.varies[0]
        figs = [Figure("threshold", "threshold of stability", [
                    {"type": "scatter", "mode": "lines+markers", "name": "threshold",
                     "x": v.values, "y": study.threshold_rpm}],
                       x_title=v.label, y_title="threshold [rpm]", speed_axis=None),
                Figure("whirl", "whirl frequency at the threshold", [
                    {"type": "scatter", "mode": "lines+markers", "name": "whirl",
                     "x": v.values, "y": study.whirl_rad_s}],
                       x_title=v.label, y_title="whirl frequency [rad/s]", speed_axis=None)]
    else:
        vx, vy = study.varies
        figs = [Figure("threshold", "threshold of stability [rpm] (blank: none found)", [
                    {"type": "heatmap", "x": vx.values, "y": vy.values, "z": study.threshold_rpm.T,
                     "colorscale": "Viridis", "colorbar": {"title": {"text": "rpm"}},
                     "hovertemplate": f"{vx.label} %{{x:.4g}}<br>{vy.label} %{{y:.4g}}"
                                      "<br>threshold %{z:.5g} rpm<extra></extra>"}],
                       x_title=vx.label, y_title=vy.label, speed_axis=None, height_px=560)]
    columns = [(k, k) for k in rows[0]]
    write_text(path, page(title, [*figs, "<h2>Points</h2>", table_html(rows, columns)]))
    return path
