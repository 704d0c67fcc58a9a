"""A figure of equal panels in rows (the studies' and checks' many-quantity plots): the grid
with its unused panels hidden, and the figure saved under a title and closed."""
from __future__ import annotations

import math
from pathlib import Path

from ..output_files import save_figure


def panel_grid(n_panels: int, max_cols: int, panel_in: tuple[float, float]):
    """``(fig, axes)``: ``n_panels`` axes (a flat list) in rows of at most ``max_cols``, each
    ``panel_in`` (width, height) inches; the rest of the last row hidden."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = max(1, min(max_cols, n_panels))
    rows = math.ceil(n_panels / cols)
    fig, grid = plt.subplots(rows, cols, figsize=(panel_in[0] * cols, panel_in[1] * rows),
                             squeeze=False)
    for ax in grid.flat[n_panels:]:
        ax.set_visible(False)
    return fig, list(grid.flat[:n_panels])


def save_panels(fig, title: str, path: Path, fontsize: float = 10) -> Path:
    """Title the figure, lay it out, write it (:func:`rotor_avc.output_files.save_figure`) and
    close it."""
    import matplotlib.pyplot as plt

    fig.suptitle(title, fontsize=fontsize)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
