"""The main job's overview page (``out/demo/index.html``): what the demo showed, on one page.

The 1x response at each bearing housing over speed, loops open (case 2) against closed (case 3),
measured in the recorded runs and modelled (the sampled loop, a dense curve per case); the
vibration reduction at each resonance, measured and predicted; the messages published and
recorded per topic of each run; the pole tables of cases 1-3; links to every report and file.
"""
from __future__ import annotations

import html
import os
from pathlib import Path

import numpy as np

from ..interactive.page import Figure, page_files, table_html, write_page

#: case -> (label, plotly colour)
CASES = {"case2": ("case 2, loops open", "#d62728"), "case3": ("case 3, loops closed", "#1f77b4")}


def response_figures(comps: dict, channels) -> list[Figure]:
    """One figure per bearing-housing channel: each case's measured 1x (markers) and its
    sampled-loop model (line), magnitudes per the comparison's reference."""
    figs = []
    for ch in channels:
        traces, unit = [], ""
        for case, comp in comps.items():
            one = comp.one_x
            if one is None or ch not in one.measured:
                continue
            label, colour = CASES[case]
            unit = one.units[ch]
            dense = one.dense_speed_rad_s["sampled"] / (2 * np.pi)
            traces.append({"type": "scatter", "mode": "lines", "name": f"{label}: model",
                           "x": dense, "y": np.abs(one.dense["sampled"][ch]),
                           "line": {"color": colour}})
            traces.append({"type": "scatter", "mode": "markers", "name": f"{label}: measured",
                           "x": one.speed_rad_s / (2 * np.pi), "y": np.abs(one.measured[ch]),
                           "marker": {"color": colour, "size": 8, "symbol": "circle-open"}})
        if traces:
            figs.append(Figure(f"onex-{ch}", f"{ch}: 1x over speed, case 2 against case 3",
                               traces, y_title="|1x|", unit=unit, magnitude_key="y"))
    return figs


def counts_table(counts: dict) -> str:
    """Per run: topic, published, recorded (from each bag's own counts)."""
    rows = [{"run": case, "topic": topic, "published": c["published"], "recorded": c["recorded"],
             "lost": (None if c["published"] is None else c["published"] - c["recorded"])}
            for case, per_topic in counts.items() for topic, c in sorted(per_topic.items())]
    return table_html(rows, [("run", "run"), ("topic", "topic"), ("published", "published"),
                             ("recorded", "recorded"), ("lost", "lost")],
                      {"lost": lambda v: "fail" if v else "num"})


def poles_tables(poles: dict) -> str:
    """Each analysis case's poles per speed (the six lowest) and its verdict."""
    out = []
    for case, per_speed in poles.items():
        for speed_hz, res in per_speed.items():
            rows = [{"re": r["re"], "im": r["im"], "freq_hz": r["freq_hz"],
                     "damping_ratio": r["damping_ratio"]} for r in res.table()[:6]]
            out.append(f"<h3>{html.escape(case)} at f_r = {speed_hz:g} Hz: "
                       f"{'stable' if res.stable else 'UNSTABLE'} (max Re {res.max_real:.3f} 1/s; "
                       "w_F iterations " + " -> ".join(f"{w:.1f}" for w in res.history)
                       + " rad/s)</h3>")
            out.append(table_html(rows, [("re", "Re [1/s]"), ("im", "Im [rad/s]"),
                                         ("freq_hz", "f [Hz]"), ("damping_ratio", "zeta")]))
    return "\n".join(out)


def links(folder: Path, files: list[Path]) -> str:
    """A list of links, relative to the page's folder; a report page with the plotly.min.js it
    loads from its folder."""
    def item(f: Path) -> str:
        rel = html.escape(os.path.relpath(f, folder))
        script = page_files(f)[1]
        needs = (f' <span class="note">(and {html.escape(os.path.relpath(script, folder))}, '
                 "which it loads)</span>" if f.suffix == ".html" and script.is_file() else "")
        return f'<li><a href="{rel}">{rel}</a>{needs}</li>'
    return "<ul>" + "".join(item(Path(f)) for f in files) + "</ul>"


def write_demo_page(path: Path, comps: dict, reductions: list[dict], counts: dict, poles: dict,
                    files: list[Path], channels) -> Path:
    """The overview page at ``path`` (see the module docstring); returns the path."""
    verdicts = ", ".join(f"{CASES[c][0]}: {'PASS' if comp.passed else 'FAIL'}"
                         for c, comp in comps.items())
    blocks = [f"<p>The Werner 2021 machine through a stepped run-up, recorded from the ROS "
              f"graph and compared with the models ({html.escape(verdicts)}).</p>",
              "<h2>Vibration reduction at each resonance</h2>",
              table_html(reductions, [("speed_hz", "speed [Hz]"), ("channel", "channel"),
                                      ("case2_db", "case 2 [dB]"), ("case3_db", "case 3 [dB]"),
                                      ("reduction_db", "measured [dB]"),
                                      ("model_reduction_db", "model [dB]")]),
              "<p class=\"note\">1x at the bearing housing that resonates most in the open loop, "
              "dB re 1 m/s for the run's unbalance; model: the sampled loop at steady state.</p>",
              "<h2>1x response at the bearing housings</h2>"]
    blocks += response_figures(comps, channels)
    blocks += ["<h2>Messages published and recorded</h2>", counts_table(counts),
               "<h2>Reports and files</h2>", links(path.parent, files),
               "<h2>Poles of cases 1-3 (worst-case procedure, Werner 2021 Fig. 4)</h2>",
               poles_tables(poles)]
    return write_page(path, "rotor_avc demo: active vibration control of the Werner 2021 machine",
                      blocks)
