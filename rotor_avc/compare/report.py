"""The report of ``rotor-avc compare``: ``index.html`` (with ``plotly.min.js`` beside it), PNG
plots, ``frf.csv`` and ``metrics.json`` in one folder (DESIGN.md section 5).

* ``metrics.json``: ``"pass"`` (true when every check against the sampled-loop model passed), the
  acceptance it tests, the run (bag, machine, sample rate, damping rule, unbalance), ``checks``
  (each with ``value``, ``tolerance``, ``unit``, ``passed``, ``detail``), the continuous model's
  values of the same metrics (``reference_model_metrics``, no verdict), per-channel 1x metrics,
  the resonances, the broadband estimates with their settings, pole summaries, notes and
  ``iso20816``: the ISO 20816-3 zone of each bearing-housing channel
  (:mod:`rotor_avc.compare.iso_zones`: ``channel``, ``rms_mm_s``, ``zone``, ``group``,
  ``support``, ``band_hz``, ``quantity``, ``windows``) and ``left_out``: the 1x points and
  broadband bins there are and those left out of the checks, counted by reason
  (:mod:`rotor_avc.compare.left_out`);
* ``frf.csv``: one row per channel and speed (``kind = 1x``) or frequency (``kind = broadband``):
  measured (H1 for broadband, with H2 and coherence), sampled-loop and continuous model, each as
  magnitude (SI unit per unit unbalance or per N) and phase in degrees, and the error in dB of
  the measurement against the sampled-loop model; broadband rows add ``h1_sigma_rel``, H1's
  normalised random error from coherence and averages, and ``averages``, the Welch segments
  behind each bin (on a gapped record, those that fit between its gaps)
  (:func:`rotor_avc.analysis.frf_estimate.h1_random_error`: the +-1 sigma band is
  ``measured_mag (1 +- h1_sigma_rel)``, drawn grey in the broadband plots where it is below 0.5);
* ``one_x_<kind>.png`` (magnitude in dB and phase over the rotational frequency: measured points,
  sampled-loop model solid, continuous dashed), ``broadband_<speed>.png`` (H1, H2, both models,
  coherence) and ``poles.png`` (continuous and sampled-loop poles at the run's speeds);
* ``index.html``: the verdict (with the points left out counted), the checks, the settings and
  interactive plots of the same data (:mod:`rotor_avc.interactive.page`: contents, zoom, pan,
  values on hover; the pole map's real parts on a symmetric-log axis), the points left out
  listed by reason in the notes.
"""
from __future__ import annotations

import csv
import html
import json
from collections import defaultdict
from itertools import chain
from pathlib import Path

import numpy as np

from .checks import (HARMONIC, MIN_COHERENCE, TOL_AT_RESONANCE_DB, TOL_OFF_RESONANCE_DB,
                     TOL_PHASE_AT_RESONANCE_DEG, TOL_PHASE_OFF_RESONANCE_DEG, TOL_RESONANCE_PCT)
from .comparison import Comparison
from ..analysis.frf_estimate import h1_random_error
from .figures import broadband_figures, one_x_figures, poles_figure
from .left_out import LeftOut, left_out_points
from ..interactive.page import key_value_table, page_files, write_page
from ..interactive.jsonable import jsonable as _clean
from ..output_files import make_folder, open_text, save_figure, write_text

ACCEPTANCE = (f"A bag of the in-process or ROS lockstep loop agrees with the sampled-loop model "
              f"within {TOL_OFF_RESONANCE_DB:g} dB and {TOL_PHASE_OFF_RESONANCE_DEG:g} deg away "
              f"from resonances and {TOL_AT_RESONANCE_DB:g} dB and "
              f"{TOL_PHASE_AT_RESONANCE_DEG:g} deg at them, and its resonance frequencies within "
              f"{TOL_RESONANCE_PCT:g} %.")
STYLE = {"sampled": dict(ls="-", lw=1.0), "continuous": dict(ls="--", lw=0.8)}
#: the broadband plots draw H1's random-error band where it is narrower than this (relative)
BAND_MAX_SIGMA = 0.5


def _summary(c: dict) -> dict:
    if "skipped" in c:
        return c
    err, ph = c["error_db"], c["phase_error_deg"]
    ok = np.isfinite(err)
    return {"checked_points": c["checked_points"], "band_rms_db": c["band_rms_db"],
            "max_abs_error_db": float(np.abs(err[ok]).max()) if ok.any() else None,
            "max_abs_phase_error_deg": float(np.abs(ph[ok]).max()) if ok.any() else None}


def metrics(comp: Comparison, iso20816=()) -> dict:
    run = comp.run
    sc = run.scenario
    out = {"pass": comp.passed, "verdict": comp.verdict,
           "no_verdict_reason": comp.no_verdict_reason, "acceptance": ACCEPTANCE,
           "bag": str(run.path), "machine": sc.machine.plant.name,
           "config_source": run.config.get("source"),
           "package_version": run.config.get("package_version"),
           "sample_rate_hz": 1.0 / run.sample_period_s, "damping": sc.damping.describe(),
           "initial_state": sc.initial_state, "unbalance": dict(sc.amplitudes),
           "assumed": run.assumptions,
           "checks": [c.as_dict() for c in comp.checks],
           "reference_model_metrics": [c.as_dict() for c in comp.reference_metrics],
           "notes": comp.notes, "iso20816": list(iso20816)}
    left = left_out_points(comp)
    out["left_out"] = {"points": left.points, "bins": left.bins,
                       "points_left_out": {r: len(v) for r, v in left.points_left_out.items()},
                       "bins_left_out": {r: sum(n for _, n in v)
                                         for r, v in left.bins_left_out.items()}}
    one = comp.one_x
    if one is not None:
        out["one_x"] = {
            "method": one.method, "settings": one.settings, "reference": one.reference,
            "speeds_hz": one.speed_rad_s / (2 * np.pi), "units": one.units,
            "channels": {ch: {m: _summary(one.channels[m][ch]) for m in one.channels}
                         for ch in one.measured},
            "resonances": one.resonances}
    out["broadband"] = [{
        "speed_hz": bb.speed_rad_s / (2 * np.pi), "w_F_rad_s": bb.w_F,
        "damping_model": f"viscous-equivalent: w_F frozen at {bb.w_F:.6g} rad/s as the run had "
                         "it (not the hysteretic model w_F = omega)",
        "input": sc.test_force.channel, "input_source": run.test_source,
        "test_signal": sc.test_force.describe(), "band_hz": bb.band_hz,
        "estimator": "H1 (checked), H2 and coherence", "min_coherence": MIN_COHERENCE,
        "settings": bb.estimate.settings(), "channels": bb.channels} for bb in comp.broadband]
    out["poles"] = [{"speed_hz": p["speed_hz"], "w_F_rad_s": p["w_F"],
                     "continuous_max_real_s": float(np.max(p["continuous"].real)),
                     "sampled_max_abs_z": p["sampled_max_abs_z"],
                     "sampled_stable": p["sampled_max_abs_z"] < 1.0} for p in comp.poles]
    return _clean(out)


def _mag_phase(v):
    return [f"{abs(x):.9g}" for x in v], [f"{np.degrees(np.angle(x)):.6g}" for x in v]


def write_csv(comp: Comparison, path: Path) -> Path:
    cols = ["kind", "speed_hz", "freq_hz", "channel", "unit", "measured_mag",
            "measured_phase_deg", "h2_mag", "h2_phase_deg", "coherence", "sampled_mag",
            "sampled_phase_deg", "continuous_mag", "continuous_phase_deg", "error_db",
            "h1_sigma_rel", "averages"]
    with open_text(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        one = comp.one_x
        if one is not None:
            f = one.speed_rad_s / (2 * np.pi)
            for ch, meas in one.measured.items():
                rows = [_mag_phase(meas), _mag_phase(one.model["sampled"][ch]),
                        _mag_phase(one.model["continuous"][ch])]
                err = one.channels["sampled"][ch].get("error_db", np.full(f.size, np.nan))
                for k in range(f.size):
                    w.writerow(["1x", f"{f[k]:.9g}", f"{f[k]:.9g}", ch, one.units[ch],
                                rows[0][0][k], rows[0][1][k], "", "", "", rows[1][0][k],
                                rows[1][1][k], rows[2][0][k], rows[2][1][k], f"{err[k]:.6g}", "",
                                ""])
        for bb in comp.broadband:
            est, sel = bb.estimate, np.isin(bb.estimate.freq_hz, bb.models["sampled"].freq_hz)
            for i, name in enumerate(bb.outputs):
                h1, h2, coh = est.h1[sel, i], est.h2[sel, i], est.coherence[sel, i]
                sigma = h1_random_error(coh, est.averages)
                s, c = bb.models["sampled"].responses[name], bb.models["continuous"].responses[name]
                with np.errstate(divide="ignore", invalid="ignore"):
                    err = 20 * np.log10(np.abs(h1) / np.abs(s))
                cols_ = [_mag_phase(h1), _mag_phase(h2), _mag_phase(s), _mag_phase(c)]
                for k, f in enumerate(est.freq_hz[sel]):
                    w.writerow(["broadband", f"{bb.speed_rad_s / (2 * np.pi):.9g}", f"{f:.9g}",
                                name, bb.models["sampled"].units[name],
                                cols_[0][0][k], cols_[0][1][k], cols_[1][0][k], cols_[1][1][k],
                                f"{coh[k]:.6g}", cols_[2][0][k], cols_[2][1][k], cols_[3][0][k],
                                cols_[3][1][k], f"{err[k]:.6g}", f"{sigma[k]:.6g}",
                                est.averages])
    return path


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _db(v):
    with np.errstate(divide="ignore"):
        return 20 * np.log10(np.abs(v))


def _one_x_groups(one) -> dict[str, dict[str, list[str]]]:
    """Kind of channel -> point -> its channels (components): one 1x figure per kind."""
    groups: dict[str, dict[str, list[str]]] = defaultdict(lambda: defaultdict(list))
    for ch in one.measured:
        point = ch.rpartition("_")[0]
        groups[ch.split("_")[0]][point].append(ch)
    return groups


def plot_one_x(comp: Comparison, out_dir: Path):
    """One PNG per kind of channel: columns = points, curves = components (yields the paths
    as written)."""
    plt, one = _plt(), comp.one_x
    f_meas = one.speed_rad_s / (2 * np.pi)
    for kind, points in _one_x_groups(one).items():
        fig, axes = plt.subplots(2, len(points), figsize=(3.4 * len(points) + 1.2, 5.6),
                                 sharex=True, squeeze=False)
        for col, (point, chans) in enumerate(points.items()):
            for j, ch in enumerate(chans):
                color = f"C{j}"
                for m, style in STYLE.items():
                    fd = one.dense_speed_rad_s[m] / (2 * np.pi)
                    axes[0, col].plot(fd, _db(one.dense[m][ch]), color=color, **style)
                    axes[1, col].plot(fd, np.degrees(np.angle(one.dense[m][ch])), color=color,
                                      **style)
                axes[0, col].plot(f_meas, _db(one.measured[ch]), "o", color=color, ms=4,
                                  mfc="none", label=ch.rpartition("_")[2])
                axes[1, col].plot(f_meas, np.degrees(np.angle(one.measured[ch])), "o",
                                  color=color, ms=4, mfc="none")
            axes[0, col].set_title(point, fontsize=9)
            axes[0, col].legend(fontsize=7)
            axes[1, col].set_xlabel("rotational frequency f_r [Hz]")
            for ax in axes[:, col]:
                ax.grid(alpha=0.3)
        axes[0, 0].set_ylabel(f"dB re 1 {one.units[next(iter(next(iter(points.values()))))]}")
        axes[1, 0].set_ylabel("phase [deg]")
        fig.suptitle(f"1x {kind}: measured (o), sampled-loop model (solid), continuous (dashed)"
                     f"\n{one.reference}", fontsize=8)
        fig.tight_layout()
        save_figure(fig, out_dir / f"one_x_{kind}.png", dpi=100)
        plt.close(fig)
        yield out_dir / f"one_x_{kind}.png"


def plot_broadband(comp: Comparison, out_dir: Path):
    """One PNG per broadband dwell (yields the paths as written)."""
    plt = _plt()
    for bb in comp.broadband:
        est = bb.estimate
        sel = np.isin(est.freq_hz, bb.models["sampled"].freq_hz)
        f = est.freq_hz[sel]
        n = len(bb.outputs)
        fig, axes = plt.subplots(3, n, figsize=(2.4 * n + 1.2, 7), sharex=True, squeeze=False)
        for i, name in enumerate(bb.outputs):
            ax = axes[:, i]
            ax[0].plot(f, _db(est.h1[sel, i]), "k", lw=0.8, label="H1")
            sigma = h1_random_error(est.coherence[sel, i], est.averages)
            shown = sigma < BAND_MAX_SIGMA
            with np.errstate(divide="ignore", invalid="ignore"):
                ax[0].fill_between(f, _db(np.abs(est.h1[sel, i]) * (1 - sigma * shown)),
                                   _db(np.abs(est.h1[sel, i]) * (1 + sigma * shown)),
                                   where=shown, color="0.8", lw=0,
                                   label=f"H1 +-1 sigma (< {BAND_MAX_SIGMA:g})")
            ax[0].plot(f, _db(est.h2[sel, i]), "0.6", lw=0.6, label="H2")
            for m, style in STYLE.items():
                r = bb.models[m].responses[name]
                ax[0].plot(f, _db(r), color="C1" if m == "sampled" else "C0", label=m, **style)
                ax[1].plot(f, np.degrees(np.angle(r)), color="C1" if m == "sampled" else "C0",
                           **style)
            ax[1].plot(f, np.degrees(np.angle(est.h1[sel, i])), "k", lw=0.8)
            ax[2].plot(f, est.coherence[sel, i], "k", lw=0.8)
            ax[2].axhline(MIN_COHERENCE, color="C3", lw=0.6)
            ax[0].set_title(name, fontsize=9)
            ax[2].set_xlabel("frequency [Hz]")
            for a in ax:
                a.grid(alpha=0.3)
        axes[0, 0].legend(fontsize=7)
        axes[0, 0].set_ylabel("dB re 1 SI unit / N")
        axes[1, 0].set_ylabel("phase [deg]")
        axes[2, 0].set_ylabel("coherence")
        speed_hz = bb.speed_rad_s / (2 * np.pi)
        fig.suptitle(f"broadband FRF from {comp.run.scenario.test_force.channel} at "
                     f"{speed_hz:.3f} Hz (w_F frozen at {bb.w_F:.4g} rad/s)", fontsize=9)
        fig.tight_layout()
        save_figure(fig, out_dir / f"broadband_{speed_hz:.1f}Hz.png", dpi=100)
        plt.close(fig)
        yield out_dir / f"broadband_{speed_hz:.1f}Hz.png"


def plot_poles(comp: Comparison, out_dir: Path):
    """The poles' PNG, when the comparison has poles (yields its path once written)."""
    if not comp.poles:
        return
    plt = _plt()
    nyquist = 0.5 / comp.run.sample_period_s
    fig, ax = plt.subplots(figsize=(7, 5))
    for k, p in enumerate(comp.poles):
        for m, marker in (("continuous", "x"), ("sampled", "o")):
            s = p[m]
            s = s[(s.imag >= 0) & (s.imag / (2 * np.pi) <= nyquist)]
            ax.plot(s.real, s.imag / (2 * np.pi), marker, color=f"C{k}", ms=5, mfc="none",
                    label=f"{m} at {p['speed_hz']:.2f} Hz")
    ax.axvline(0.0, color="k", lw=0.6)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlabel("Re s [1/s] (symmetric log scale)")
    ax.set_ylabel("Im s / 2 pi [Hz]")
    ax.set_title("closed-loop poles with the run's damping (x continuous, o sampled loop)",
                 fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    path = out_dir / "poles.png"
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    yield path


def _table(rows: list[list], head: list[str]) -> str:
    cells = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>"
                   for r in rows)
    return f"<table><tr>{cells}</tr>{body}</table>"


def _fmt(v) -> str:
    return "-" if v is None else f"{v:.4g}"


def iso_table(entries) -> str:
    """The ISO 20816-3 entries as a small HTML table."""
    return _table([[e["channel"], f"{e['rms_mm_s']:.4g}", e["zone"], e["quantity"]]
                   for e in entries], ["channel", "r.m.s. velocity [mm/s]", "zone", "quantity"])


def iso_heading(entries) -> str:
    """The heading and the basis of :func:`iso_table`."""
    if not entries:
        return "<h2>ISO 20816-3 zones</h2><p>No bearing-housing channel evaluated.</p>"
    e = entries[0]
    return (f"<h2>ISO 20816-3 zones</h2><p class=\"note\">Group {e['group']}, {e['support']} "
            f"support (Annex A); broadband r.m.s. velocity over {e['band_hz'][0]:g} .. "
            f"{e['band_hz'][1]:g} Hz, the largest of the sliding windows (module "
            "rotor_avc.compare.iso_zones); a value on a boundary lies in the lower zone.</p>")


def verdict_text(comp: Comparison, left: LeftOut) -> str:
    """The verdict with the points left out counted: ``PASS, 64 of 126 1x points left out (...)``."""
    summary = left.summary()
    return comp.verdict + (f", {summary}" if summary else "")


def _resonances(data: dict) -> str:
    """The resonances of the models against the measured ones (those not resolved with the
    reason), or why there are none."""
    one = data.get("one_x")
    if one is None:
        return "<p>No 1x response in this run (see the notes), so no resonance to compare.</p>"
    rows = one["resonances"]
    if not rows:
        lo, hi = min(one["speeds_hz"]), max(one["speeds_hz"])
        why = ("the harmonic controller's forces drive the models, whose curves over speed are "
               "the feedback loop alone" if any(ch.startswith(HARMONIC) for ch in one["channels"])
               else f"no resonance peak of the models lies within the measured speeds "
                    f"({lo:.4g} .. {hi:.4g} Hz) on a channel that is compared")
        return f"<p>No resonance compared: {html.escape(why)}.</p>"
    body = [[r["model"], r["channel"], f"{r['model_hz']:.4f}",
             f"{r['measured_hz']:.4f}" if "measured_hz" in r else "-",
             f"{r['freq_error_pct']:.3f}" if "measured_hz" in r else "-",
             f"{r['level_error_db']:.3f}" if "measured_hz" in r else "-",
             r.get("not_resolved", "")] for r in rows]
    return _table(body, ["model", "channel", "model [Hz]", "measured [Hz]", "error [%]",
                         "peak error [dB]", "not resolved because"])


def _settings(data: dict) -> str:
    """The 1x order tracking and broadband estimation settings as key/value tables."""
    out = []
    if "one_x" in data:
        one = data["one_x"]
        out += [f"<h3>1x: {html.escape(one['method'])}</h3>",
                key_value_table({"normalisation": one["reference"], **one["settings"]})]
    for bb in data["broadband"]:
        out += [f"<h3>Broadband at {bb['speed_hz']:.3f} Hz</h3>", key_value_table({
            "estimator": bb["estimator"], "input": f"{bb['input']} ({bb['input_source']})",
            "test signal": bb["test_signal"], "min coherence": bb["min_coherence"],
            "damping model": bb["damping_model"], **bb["settings"]})]
    return "".join(out)


def write_html(comp: Comparison, data: dict, pngs: list[Path], path: Path) -> Path:
    left = left_out_points(comp)
    verdict = verdict_text(comp, left)
    checks = _table([[{True: "pass", False: "FAIL", None: "-"}[c.passed], c.name, _fmt(c.value),
                      f"{c.tolerance:g} {c.unit}", c.detail] for c in comp.checks],
                    ["verdict", "check (sampled-loop model)", "value", "tolerance", "detail"])
    ref = _table([[c.name, _fmt(c.value), c.unit, c.detail] for c in comp.reference_metrics],
                 ["metric (continuous model, no verdict)", "value", "unit", "detail"])
    info = {"bag": data["bag"], "machine": data["machine"],
            "sample rate": f"{data['sample_rate_hz']:g} Hz", "damping": data["damping"],
            "initial state": data["initial_state"]}
    poles = _table([[f"{q['speed_hz']:.3f}", f"{q['w_F_rad_s']:.4g}",
                     f"{q['continuous_max_real_s']:.4g}", f"{q['sampled_max_abs_z']:.6f}",
                     "yes" if q["sampled_stable"] else "NO"] for q in data["poles"]],
                   ["speed [Hz]", "w_F [rad/s]", "continuous max Re s [1/s]",
                    "sampled max |z|", "sampled loop stable"])
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in left.notes() + comp.notes)
    files = ", ".join(f'<a href="{html.escape(p.name)}">{html.escape(p.name)}</a>'
                      for p in pngs)
    css_verdict = "pass" if comp.passed else "fail"
    blocks = [f'<p class="{css_verdict}" style="font-size:20px">{html.escape(verdict)}</p>'
              f"<p>{html.escape(ACCEPTANCE)} This run: <b>{comp.verdict}</b>"
              f"{html.escape(verdict[len(comp.verdict):])}"
              f"{html.escape(' -- ' + comp.no_verdict_reason) if comp.no_verdict_reason else ''}"
              ".</p>", "<h2>Checks</h2>", checks,
              "<h2>Continuous model (the papers' FRFs), for reference</h2>", ref,
              "<h2>Run</h2>", key_value_table(info), _settings(data),
              "<h2>Resonances (measured vs model)</h2>", _resonances(data),
              "<h2>Poles with the run's damping</h2>", poles, *poles_figure(comp),
              iso_heading(data["iso20816"]), iso_table(data["iso20816"]),
              f"<h2>Notes</h2><ul>{notes or '<li>none</li>'}</ul>"]
    if comp.one_x is not None:
        blocks += ["<h2>1x response over speed</h2>", *one_x_figures(comp)]
    if comp.broadband:
        blocks += ["<h2>Broadband FRFs</h2>", *broadband_figures(comp)]
    blocks.append(f"<p>Files next to this page: frf.csv, metrics.json and the PNGs ({files}).</p>")
    return write_page(path, f"Comparison of a recorded run with the models: {data['bag']}",
                      blocks)


def write_report(comp: Comparison, out_dir, iso20816=(), progress=None) -> dict[str, Path]:
    """Write the report folder (``iso20816``: the entries of
    :func:`rotor_avc.compare.iso_zones.iso20816_entries`); returns the paths by role.
    ``progress``: called ``(figures written, figures)`` after each PNG (None: quiet)."""
    out_dir = Path(out_dir)
    make_folder(out_dir)
    data = metrics(comp, iso20816)
    write_text(out_dir / "metrics.json", json.dumps(data, indent=1))
    csv_path = write_csv(comp, out_dir / "frf.csv")
    figures = ((len(_one_x_groups(comp.one_x)) if comp.one_x else 0) + len(comp.broadband)
               + bool(comp.poles))
    pngs = []
    for path in chain(plot_one_x(comp, out_dir) if comp.one_x else (),
                      plot_broadband(comp, out_dir), plot_poles(comp, out_dir)):
        pngs.append(path)
        if progress is not None:
            progress(len(pngs), figures)
    page = write_html(comp, data, pngs, out_dir / "index.html")
    return {"index": page, "plotly": page_files(page)[1], "metrics": out_dir / "metrics.json",
            "csv": csv_path, "plots": pngs}
