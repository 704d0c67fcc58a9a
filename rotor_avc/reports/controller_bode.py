"""The Bode plots of `rotor-avc controller`: a foot controller continuous and discrete, and the
figure layout the loop plots (:mod:`rotor_avc.reports.loop_plots`) share."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..output_files import save_figure


def pyplot():
    """matplotlib's pyplot on the Agg backend (imported only when a plot is drawn)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save_bode(fig, ax1, ax2, path: Path, title: str, magnitude_label: str, xlabel: str) -> Path:
    """A magnitude-over-phase figure finished (phase axis in 90 deg steps, labels, grid, legend,
    title), saved to ``path`` and closed."""
    ax2.set_ylim(-190, 190)
    ax2.set_yticks(np.arange(-180, 181, 90))
    ax1.set_ylabel(magnitude_label)
    ax2.set_ylabel("phase [deg]")
    ax2.set_xlabel(xlabel)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, which="both")
    ax1.legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    pyplot().close(fig)
    return path


def plot_bode(ctrl, tf, path: Path, title: str) -> Path:
    """``|G_c(jw)|`` and phase against the discrete filter ``G_d(e^{jwT})`` up to Nyquist."""
    plt = pyplot()
    nyq = 0.5 / tf.sample_period_s
    f = np.logspace(np.log10(nyq) - 5, np.log10(nyq), 800)
    w = 2 * np.pi * f
    gc, gd = ctrl(1j * w), tf.frequency_response(w)
    db_c = 20 * np.log10(np.abs(gc))
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    ax1.semilogx(f, db_c, label="G_c(jw), continuous")
    with np.errstate(divide="ignore"):
        ax1.semilogx(f, 20 * np.log10(np.abs(gd)), "--", label=f"G_d(e^(jwT)), {tf.method}")
    ax2.semilogx(f, np.degrees(np.angle(gc)))
    ax2.semilogx(f, np.degrees(np.angle(gd)), "--")
    ax1.set_ylim(db_c.min() - 40, db_c.max() + 20)     # a Tustin zero at Nyquist dives to -inf
    return save_bode(fig, ax1, ax2, path, title, "magnitude [dB re 1 SI]",
                     f"frequency [Hz] (Nyquist {nyq:g} Hz)")
