"""Control-performance metrics: RMS, insertion loss (Sci. Rep. 2023 eq. 43) and its zero crossing.

``IL [dB] = 20 log10(before / after)``: positive means reduction, and 0 dB is the paper's control
criterion (Fig. 7). For a steady single-frequency response the RMS of a sinusoid of amplitude
``|X|`` is ``|X| / sqrt(2)``, so IL from phasor amplitudes equals IL from RMS values.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.optimize


def signal_rms(x, axis: int = -1) -> np.ndarray:
    """``sqrt(mean(x^2))`` of sampled signals (the RMS of Sci. Rep. 2023, Table 2)."""
    x = np.asarray(x, dtype=float)
    return np.sqrt(np.mean(x * x, axis=axis))


def phasor_rms(amplitude) -> np.ndarray:
    """RMS of the steady sinusoid ``Re{X e^{j Omega t}}``: ``|X| / sqrt(2)``."""
    return np.abs(amplitude) / np.sqrt(2.0)


def insertion_loss_db(before, after) -> np.ndarray:
    """Eq. (43) from amplitudes or RMS values (``after = 0`` gives +inf: perfect cancellation)."""
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(np.abs(before)) - 20.0 * np.log10(np.abs(after))


def first_sign_change(fn: Callable[[np.ndarray], np.ndarray], grid,
                      xtol: float = 1e-6) -> float | None:
    """Lowest ``x`` of an ascending ``grid`` range where ``fn`` turns negative: the first grid
    interval where ``fn`` goes from >= 0 to < 0, refined by Brent's method (``grid[0]`` when
    ``fn`` is already negative there; None when it stays >= 0). ``fn`` maps an array of ``x``
    to an array of values."""
    grid = np.asarray(grid, dtype=float)
    values = np.asarray(fn(grid), dtype=float)
    negative = np.flatnonzero(values < 0)
    if negative.size == 0:
        return None
    k = negative[0]
    if k == 0:
        return float(grid[0])
    a, b = grid[k - 1], grid[k]
    return float(scipy.optimize.brentq(lambda x: float(fn(np.array([x]))[0]), a, b,
                                       xtol=xtol * max(abs(b), 1.0)))
