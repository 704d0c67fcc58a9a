"""How far noise lets a recorded 1x phasor be trusted: its random error from the residual.

Over a window of whole revolutions the 1x phasor is the least-squares fit of
``y = Re{Y e^{j theta}} + c`` (rotor_avc.analysis.order_tracking). With white residual noise of
variance ``s^2`` over ``N`` samples each quadrature component of ``Y`` has the standard error
``s sqrt(2 / N)``, so the magnitude's relative standard error is ``eps = s sqrt(2 / N) / |Y|``
and a magnitude check of tolerance ``tol`` dB can be decided only when its
``k``-sigma interval ``20 log10(1 + k eps)`` stays below ``tol``.
"""
from __future__ import annotations

import numpy as np


def one_x_random_error(angle_rad, values) -> tuple[complex, float]:
    """``(Y, eps)``: the 1x phasor of ``values`` over ``angle_rad`` (least squares with an
    offset) and its magnitude's relative standard error from the residual."""
    theta = np.asarray(angle_rad, dtype=float)
    y = np.asarray(values, dtype=float)
    basis = np.column_stack([np.cos(theta), np.sin(theta), np.ones_like(theta)])
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    resid = y - basis @ coef
    s = np.sqrt(resid @ resid / max(y.size - 3, 1))
    phasor = complex(coef[0], -coef[1])
    with np.errstate(divide="ignore"):
        return phasor, float(s * np.sqrt(2.0 / y.size) / abs(phasor))


def decidable(eps: float, tol_db: float, sigmas: float = 2.0) -> tuple[bool, float]:
    """``(ok, half-width dB)``: whether the ``sigmas`` interval of a magnitude with relative
    error ``eps`` fits inside ``tol_db``."""
    width = float(20.0 * np.log10(1.0 + sigmas * eps))
    return width <= tol_db, width
