"""PNG plots of a run-up (rotor_avc.compare.runup_views): waterfall, 1x Bode and polar plots per
channel, bearing-housing orbits."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..compare.runup_views import OneXTrack, Orbit, Waterfall
from .campbell_plot import speed_axis
from ..output_files import save_figure

ORDERS = (1, 2, 3, 4)
#: the waterfall's colour range below its peak, in dB (the PNG and the interactive page)
WATERFALL_RANGE_DB = 80.0


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    _pyplot().close(fig)
    return path


def waterfall_levels(wf: Waterfall, max_freq_hz: float | None = None):
    """``(top frequency [Hz], bins shown, amplitude in dB re 1 SI unit, its peak)`` of the
    waterfall up to ``max_freq_hz`` (default 1.2 x the highest order at the top speed)."""
    top = max_freq_hz or 1.2 * max(ORDERS) * wf.speed_hz.max()
    sel = wf.freq_hz <= top
    with np.errstate(divide="ignore"):
        level = 20 * np.log10(wf.amplitude[:, sel])
    return top, sel, level, float(level[np.isfinite(level)].max())


def plot_waterfall(wf: Waterfall, unit: str, path: Path, speed_unit: str = "hz",
                   max_freq_hz: float | None = None) -> Path:
    """Amplitude (dB re 1 SI unit) over rotor speed and frequency, orders marked."""
    plt = _pyplot()
    factor, xlabel = speed_axis(speed_unit)
    top, sel, level, peak = waterfall_levels(wf, max_freq_hz)
    fig, ax = plt.subplots(figsize=(8, 5.5))
    mesh = ax.pcolormesh(wf.speed_hz * factor, wf.freq_hz[sel], level.T, shading="nearest",
                         cmap="magma", vmin=peak - WATERFALL_RANGE_DB, vmax=peak)
    fig.colorbar(mesh, ax=ax, label=f"amplitude [dB re 1 {unit}]")
    for k in ORDERS:
        ax.plot(wf.speed_hz * factor, k * wf.speed_hz, "w--", lw=0.7)
        ax.annotate(f"{k}x", (wf.speed_hz[-1] * factor, min(k * wf.speed_hz[-1], top)),
                    color="w", fontsize=8, ha="right", va="bottom")
    ax.set_ylim(0, top)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("frequency [Hz]")
    ax.set_title(f"waterfall of {wf.channel}", fontsize=10)
    return _save(fig, path)


def plot_bode(track: OneXTrack, channel: str, path: Path, speed_unit: str = "hz") -> Path:
    """1x amplitude (log scale, SI) and phase over speed: measured points, model line."""
    plt = _pyplot()
    factor, xlabel = speed_axis(speed_unit)
    x, xm = track.speed_hz * factor, track.model_speed_hz * factor
    meas, model = track.measured[channel], track.model[channel]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    ax1.semilogy(xm, np.abs(model), "-", lw=1, label="model (continuous loop)")
    ax1.semilogy(x, np.abs(meas), "o", ms=3, label="measured 1x")
    ax2.plot(xm, np.degrees(np.angle(model)), "-", lw=1)
    ax2.plot(x, np.degrees(np.angle(meas)), "o", ms=3)
    ax1.set_ylabel(f"1x amplitude [{track.units[channel]}]")
    ax2.set_ylabel("1x phase [deg]")
    ax2.set_xlabel(xlabel)
    ax1.legend(fontsize=8)
    ax1.set_title(f"1x Bode plot of {channel}", fontsize=10)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
    return _save(fig, path)


def plot_polar(track: OneXTrack, channel: str, path: Path, speed_unit: str = "hz") -> Path:
    """1x phasor in the complex plane over speed (Nyquist plot), some speeds labelled."""
    plt = _pyplot()
    factor, xlabel = speed_axis(speed_unit)
    meas, model = track.measured[channel], track.model[channel]
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    ax.plot(model.real, model.imag, "-", lw=1, label="model (continuous loop)")
    ax.plot(meas.real, meas.imag, "o-", ms=3, lw=0.5, label="measured 1x")
    for i in np.linspace(0, meas.size - 1, 6).astype(int):
        ax.annotate(f"{track.speed_hz[i] * factor:.0f}", (meas.real[i], meas.imag[i]), fontsize=7)
    ax.axhline(0, color="k", lw=0.5)
    ax.axvline(0, color="k", lw=0.5)
    ax.set_aspect("equal", adjustable="datalim")
    unit = track.units[channel]
    ax.set_xlabel(f"Re [{unit}]")
    ax.set_ylabel(f"Im [{unit}]")
    ax.legend(fontsize=8)
    ax.set_title(f"1x polar plot of {channel} (labels: {xlabel.split('[')[1][:-1]})", fontsize=10)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def plot_orbits(orbits: list[Orbit], path: Path, speed_unit: str = "hz") -> Path:
    """Displacement orbits (first channel horizontal, second vertical) in micrometres."""
    plt = _pyplot()
    factor, xlabel = speed_axis(speed_unit)
    points = sorted({o.point for o in orbits})
    speeds = sorted({o.speed_hz for o in orbits})
    fig, axes = plt.subplots(len(points), len(speeds), figsize=(3.2 * len(speeds), 3.2 * len(points)),
                             squeeze=False)
    for o in orbits:
        ax = axes[points.index(o.point), speeds.index(o.speed_hz)]
        ax.plot(o.raw_m[:, 0] * 1e6, o.raw_m[:, 1] * 1e6, lw=0.5, color="0.6", label="raw")
        ax.plot(o.one_x_m[:, 0] * 1e6, o.one_x_m[:, 1] * 1e6, lw=1.5, label="1x")
        ax.plot(o.key_m[0] * 1e6, o.key_m[1] * 1e6, "ko", ms=4)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{o.point} at {o.speed_hz * factor:.4g} {xlabel.split('[')[1][:-1]}", fontsize=9)
        ax.set_xlabel(f"{o.axes[0]} displacement [um]", fontsize=8)
        ax.set_ylabel(f"{o.axes[1]} displacement [um]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    return _save(fig, path)
