"""The strategy study's report: ``strategies.csv``, PNG plots (1x per sensor over time and over
speed, per strategy) and a self-contained ``index.html`` with the table and the plots."""
from __future__ import annotations

import base64
import csv
import html
from pathlib import Path

import numpy as np

from ..compare.report import _plt, _table
from ..output_files import make_folder, open_text, save_figure, write_text


def _fmt(v, digits=3) -> str:
    return "-" if v is None else f"{v:.{digits}g}"


def rows(results, sensors) -> tuple[list[str], list[list]]:
    head = (["strategy"] + [f"1x {s} (dB)" for s in sensors]
            + ["time to -20 dB (s)", "peak force (N)", "peak foot displacement (m)",
               "analysed at (Hz)", "max |z| per revolution", "gain margin",
               "phase limit (deg)", "exact phase limit (deg)"])
    out = []
    for r in results:
        rb = r.robustness
        out.append([r.name] + [f"{v:.1f}" for v in r.attenuation_db]
                   + [_fmt(r.time_to_20db_s), _fmt(r.peak_force_n),
                      _fmt(r.peak_foot_displacement_m),
                      _fmt(rb.get("speed_hz"), 4), _fmt(rb.get("max_abs_z_per_rev"), 5),
                      _fmt(rb.get("gain_margin")), _fmt(rb.get("phase_limit_deg")),
                      _fmt(rb.get("exact_phase_limit_deg"))])
    return head, out


def plots(results, sensors, out_dir: Path) -> list[Path]:
    plt = _plt()
    paths = []
    for axis, label in (("time_s", "time (s)"), ("speed_hz", "speed (Hz)")):
        if axis == "speed_hz" and all(np.ptp(r.speed_hz) < 1e-9 for r in results):
            continue                                   # constant speed: no speed axis
        fig, axes = plt.subplots(len(sensors), 1, figsize=(9, 3 * len(sensors)), squeeze=False)
        for i, s in enumerate(sensors):
            ax = axes[i, 0]
            for r in results:
                ax.plot(getattr(r, axis), r.level_db[:, i], label=r.name)
            ax.set_ylabel(f"1x {s} re no control (dB)")
            ax.grid(True)
        axes[-1, 0].set_xlabel(label)
        axes[0, 0].legend(fontsize=7)
        fig.tight_layout()
        paths.append(out_dir / f"one_x_vs_{axis.split('_')[0]}.png")
        save_figure(fig, paths[-1], dpi=90)
        plt.close(fig)
    return paths


def write_report(results, sensors, out_dir: Path, source: str, plot: bool = True) -> Path:
    make_folder(out_dir)
    head, body = rows(results, sensors)
    with open_text(out_dir / "strategies.csv", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(head)
        w.writerows(body)
    pngs = plots(results, sensors, out_dir) if plot else []
    imgs = "".join(f"<h3>{html.escape(p.name)}</h3><img src='data:image/png;base64,"
                   f"{base64.b64encode(p.read_bytes()).decode()}'/>" for p in pngs)
    peaks = ""
    if results and results[0].peak_reduction_db:
        keys = list(results[0].peak_reduction_db)
        p_head = ["strategy"] + [f"{n} {f:.1f} Hz" for n, f in keys]
        p_body = [[r.name] + [f"{r.peak_reduction_db.get(k, float('nan')):.1f}" for k in keys]
                  for r in results]
        peaks = ("<h2>1x peak reduction at the model's resonances (dB)</h2>"
                 + _table(p_body, p_head))
        with open_text(out_dir / "peak_reductions.csv", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(p_head)
            w.writerows(p_body)
    text = (f"<html><head><meta charset='utf-8'><title>strategies</title></head><body>"
            f"<h1>Vibration control strategies</h1><p>{html.escape(source)}: 1x per sensor re "
            f"the uncontrolled run (mean of the last revolutions), time to stay 20 dB below it "
            f"after the harmonic switch-on, peak actuator force and foot displacement, exact "
            f"one-revolution loop radius and quasi-steady phase-error limit of the harmonic "
            f"law.</p>{_table(body, head)}{peaks}{imgs}</body></html>")
    path = out_dir / "index.html"
    write_text(path, text)
    return path
