"""How far noise lets a recorded 1x phasor be trusted: its random error from the residual.

Over a window of whole revolutions the 1x phasor is the least-squares fit of
``y = Re{Y e^{j theta}} + c`` (rotor_avc.analysis.order_tracking). With white residual noise of
variance ``s^2`` over ``N`` samples each quadrature component of ``Y`` has the standard error
``s sqrt(2 / N)``, so the magnitude's relative standard error is ``eps = s sqrt(2 / N) / |Y|``
(``sigma / |Y|`` of :func:`rotor_avc.analysis.order_tracking.fit`), and a magnitude check
of tolerance ``tol`` dB can be decided only when its
``k``-sigma interval ``20 log10(1 + k eps)`` stays below ``tol``.
"""
from __future__ import annotations

import numpy as np


def decidable(eps: float, tol_db: float, sigmas: float = 2.0) -> tuple[bool, float]:
    """``(ok, half-width dB)``: whether the ``sigmas`` interval of a magnitude with relative
    error ``eps`` fits inside ``tol_db``."""
    width = float(20.0 * np.log10(1.0 + sigmas * eps))
    return width <= tol_db, width
