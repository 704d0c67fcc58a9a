"""``<machine>_<feedback>.html`` of ``rotor-avc study``: the response over speed per gain and the
resonance shifts and reductions over gain, interactive (:mod:`rotor_avc.interactive.page`; the
gains in order along a sequential colour scale)."""
from __future__ import annotations

from pathlib import Path

from ..analysis.gain_study import GainStudy
from ..interactive.page import Figure, write_page


def write_study_html(study: GainStudy, path: Path, gain_label: str) -> Path:
    title = (f"{study.structure} on {study.feedback}, {study.gain_name} = {study.gains[1]:g} .. "
             f"{study.gains[-1]:g} ({study.excitation} excitation)")
    speed_hz = study.speed_rpm / 60.0
    blocks = ["<h2>Response over speed per gain</h2>"]
    for q, curves in study.curves.items():
        traces = [{"type": "scatter", "mode": "lines", "name": f"{study.gain_name} = {g:g}",
                   "x": speed_hz, "y": curves[i]} for i, g in enumerate(study.gains)]
        blocks.append(Figure(f"curve-{q}", q, traces, y_title="amplitude", unit=study.units[q],
                             magnitude_key="y", height_px=360))
    blocks.append("<h2>Resonances over gain</h2>")
    traces = [{"type": "scatter", "mode": "lines+markers", "name": r.label, "x": study.gains,
               "y": r.speed_rpm / 60.0} for r in study.resonances]
    blocks.append(Figure("resonance-speed", "resonance speed over gain", traces,
                         x_title=gain_label, y_title="resonance speed", speed_axis="y",
                         height_px=360))
    traces = [{"type": "scatter", "mode": "lines+markers", "name": r.label, "x": study.gains,
               "y": r.reduction_window_pct} for r in study.resonances]
    blocks.append(Figure("resonance-reduction", "reduction of the resonance peak (window) over "
                         "gain", traces, x_title=gain_label,
                         y_title="reduction of the resonance peak [%]", speed_axis=None,
                         height_px=360))
    return write_page(path, title, blocks)
