"""The loop plots of `rotor-avc controller`: Bode and Nyquist of one foot's loop ``L_i``.

``L_i`` is the loop broken at the foot's actuator input with the other loops closed
(:mod:`rotor_avc.analysis.loop_margins`); the sampled loop is drawn solid up to Nyquist, the
continuous design dashed. Marked: the gain crossover and phase margin, the phase crossover and
gain margin (Skogestad & Postlethwaite 2005 sec. 2.4.3), and on the Nyquist plot the -1 point,
the unit circle and the circle of radius ``1/Ms`` around -1 that the locus touches.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..output_files import save_figure
from .controller_bode import pyplot, save_bode

#: half-width of the Nyquist plot's window around the origin when the locus goes further
NYQUIST_WINDOW = 3.0


def _label(m, rate: str) -> str:
    gm = "inf" if np.isinf(m.gain_margin) else f"{m.gain_margin_db:.1f} dB"
    pm = "none" if np.isinf(m.phase_margin_deg) else f"{m.phase_margin_deg:.1f} deg"
    return f"{rate}: GM {gm}, PM {pm}, Ms {m.sensitivity_peak:.3g}"


def plot_loop_bode(sampled, continuous, path: Path, title: str) -> Path:
    """``|L_i|`` and phase of the sampled loop (solid) and the continuous design (dashed), with
    the sampled loop's crossovers and margins marked."""
    plt = pyplot()
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True)
    for m, style, rate in ((continuous, "--", "continuous"), (sampled, "-", "sampled")):
        f = m.w_rad_s / (2 * np.pi)
        with np.errstate(divide="ignore"):
            ax1.semilogx(f, 20 * np.log10(np.abs(m.response)), style, lw=1, label=_label(m, rate))
        ax2.semilogx(f, np.degrees(np.angle(m.response)), style, lw=1)
    ax1.axhline(0.0, color="k", lw=0.6)
    for ph in (-180, 180):
        ax2.axhline(ph, color="k", lw=0.6)
    if np.isfinite(sampled.crossover_hz):
        for ax in (ax1, ax2):
            ax.axvline(sampled.crossover_hz, color="tab:green", lw=0.8, ls=":")
        ax2.annotate(f"PM {sampled.phase_margin_deg:.1f} deg\nat {sampled.crossover_hz:.4g} Hz",
                     (sampled.crossover_hz, 0.0), fontsize=8, color="tab:green")
    if np.isfinite(sampled.phase_crossover_hz):
        for ax in (ax1, ax2):
            ax.axvline(sampled.phase_crossover_hz, color="tab:red", lw=0.8, ls=":")
        ax1.plot([sampled.phase_crossover_hz] * 2, [0.0, -sampled.gain_margin_db], color="tab:red",
                 lw=2)
        ax1.annotate(f"GM {sampled.gain_margin_db:.1f} dB (x{sampled.gain_margin:.3g})\nat "
                     f"{sampled.phase_crossover_hz:.4g} Hz",
                     (sampled.phase_crossover_hz, -sampled.gain_margin_db), fontsize=8,
                     color="tab:red", ha="right")
    mag = 20 * np.log10(np.abs(sampled.response[np.abs(sampled.response) > 0]))
    ax1.set_ylim(max(mag.min(), mag.max() - 120) - 10, mag.max() + 10)
    ax2.set_xlim(sampled.w_rad_s[0] / (2 * np.pi), 5 * sampled.w_rad_s[-1] / (2 * np.pi))
    return save_bode(fig, ax1, ax2, path, title, "|L_i| [dB]", "frequency [Hz]")


def plot_loop_nyquist(sampled, continuous, path: Path, title: str) -> Path:
    """The Nyquist plot of ``L_i`` (positive frequencies; the mirror image thin), the -1 point,
    the unit circle and the ``1/Ms`` circle around -1, zoomed on the origin."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    for m, style, rate in ((continuous, "--", "continuous"), (sampled, "-", "sampled")):
        line, = ax.plot(m.response.real, m.response.imag, style, lw=1, label=_label(m, rate))
        ax.plot(m.response.real, -m.response.imag, style, lw=0.4, color=line.get_color())
    t = np.linspace(0, 2 * np.pi, 361)
    ax.plot(np.cos(t), np.sin(t), color="0.6", lw=0.8, label="unit circle")
    r = 1.0 / sampled.sensitivity_peak
    ax.plot(-1 + r * np.cos(t), r * np.sin(t), color="tab:red", lw=0.8,
            label=f"1/Ms = {r:.3g} around -1 (sampled)")
    ax.plot([-1], [0], "rx", ms=9)
    reach = max(np.abs(sampled.response).max(), np.abs(continuous.response).max())
    half = min(NYQUIST_WINDOW, 1.2 * max(reach, 1.2))
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_aspect("equal")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.axvline(0.0, color="k", lw=0.5)
    ax.set_xlabel("Re L_i")
    ax.set_ylabel("Im L_i")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    zoom = f" (window +-{half:g}; |L_i| reaches {reach:.3g})" if reach > half else ""
    fig.suptitle(title + zoom, fontsize=9)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
