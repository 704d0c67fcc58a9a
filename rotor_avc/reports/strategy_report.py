"""The strategy study's report: ``strategies.csv`` (and ``peak_reductions.csv`` over a run-up),
PNG plots (1x per sensor over time and over speed, per strategy) and ``index.html``, an
interactive page like the other reports (:mod:`rotor_avc.interactive.page`): the table, the 1x
per sensor re the uncontrolled run over time and over speed, the peak reductions at the model's
resonances."""
from __future__ import annotations

import csv
import html
from pathlib import Path

import numpy as np

from ..compare.report import _plt
from ..interactive.page import Figure, table_html, write_page
from ..output_files import make_folder, open_text, save_figure

#: what the table's columns mean (the page's introduction)
INTRODUCTION = ("1x per sensor re the uncontrolled run (mean of the last revolutions), time to "
                "stay 20 dB below it after the harmonic switch-on, peak actuator force and foot "
                "displacement, exact one-revolution loop radius and quasi-steady phase-error "
                "limit of the harmonic law.")


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


def peak_rows(results) -> tuple[list[str], list[list]]:
    """The run-up's 1x peak reductions: heading and one row per strategy (empty: none)."""
    if not results or not results[0].peak_reduction_db:
        return [], []
    keys = list(results[0].peak_reduction_db)
    head = ["strategy"] + [f"{n} {f:.1f} Hz" for n, f in keys]
    return head, [[r.name] + [f"{r.peak_reduction_db.get(k, float('nan')):.1f}" for k in keys]
                  for r in results]


def _axes(results) -> list[tuple[str, str]]:
    """``(StrategyResult attribute, label)`` of the x axes: time, and speed over a run-up."""
    axes = [("time_s", "time (s)")]
    if not all(np.ptp(r.speed_hz) < 1e-9 for r in results):
        axes.append(("speed_hz", "speed (Hz)"))
    return axes


def plots(results, sensors, out_dir: Path) -> list[Path]:
    plt = _plt()
    paths = []
    for axis, label in _axes(results):
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


def figures(results, sensors) -> list:
    """The page's plots: per sensor and x axis, the 1x re no control of every strategy; the
    peak reductions as bars."""
    out = []
    for axis, label in _axes(results):
        speed = axis == "speed_hz"
        for i, s in enumerate(sensors):
            traces = [{"type": "scatter", "mode": "lines", "name": r.name,
                       "x": getattr(r, axis), "y": r.level_db[:, i]} for r in results]
            out.append(Figure(f"one-x-{axis}-{i}", f"1x at {s} re no control over "
                              f"{label.split(' ')[0]}", traces,
                              x_title="rotor speed" if speed else label,
                              y_title="1x re no control [dB]",
                              speed_axis="x" if speed else None, height_px=380))
    head, body = peak_rows(results)
    if body:
        out.append(Figure("peak-reductions", "1x peak reduction at the model's resonances",
                          [{"type": "bar", "name": row[0], "x": head[1:],
                            "y": [float(v) for v in row[1:]]} for row in body[1:]],
                          x_title="sensor and resonance", y_title="reduction [dB]",
                          speed_axis=None, layout={"barmode": "group"}))
    return out


def _write_csv(path: Path, head, body) -> None:
    with open_text(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(head)
        w.writerows(body)


def write_report(results, sensors, out_dir: Path, source: str, plot: bool = True) -> Path:
    make_folder(out_dir)
    head, body = rows(results, sensors)
    _write_csv(out_dir / "strategies.csv", head, body)
    files = ["strategies.csv"]
    p_head, p_body = peak_rows(results)
    if p_body:
        _write_csv(out_dir / "peak_reductions.csv", p_head, p_body)
        files.append("peak_reductions.csv")
    files += [p.name for p in (plots(results, sensors, out_dir) if plot else [])]

    def table(h, b):
        return table_html([dict(zip(h, r)) for r in b], [(k, k) for k in h])

    blocks = [f"<p>{html.escape(source)}: {html.escape(INTRODUCTION)}</p>",
              "<h2>Strategies</h2>", table(head, body)]
    if p_body:
        blocks += ["<h2>1x peak reduction at the model's resonances (dB)</h2>",
                   table(p_head, p_body)]
    blocks += ["<h2>1x over the run</h2>", *figures(results, sensors),
               "<p>Files next to this page: " + ", ".join(
                   f'<a href="{html.escape(n)}">{html.escape(n)}</a>' for n in files) + ".</p>"]
    return write_page(out_dir / "index.html", f"Vibration control strategies: {source}", blocks)
