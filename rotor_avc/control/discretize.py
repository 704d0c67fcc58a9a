"""Discretisation of a controller G_c(s) (Werner 2021 eq. 6) at a sample period T (DESIGN.md 3).

``discretize_controller(ctrl, T, method, prewarp_hz)`` returns the difference equation
``a[0] y_k + a[1] y_{k-1} + ... = b[0] x_k + b[1] x_{k-1} + ...`` (``a[0] = 1``, ``b`` and ``a``
of equal length) of the filter a digital controller runs on its sampled feedback signal. The
design is scipy's :func:`scipy.signal.cont2discrete`:

* ``tustin`` -- bilinear ``s = (2/T)(z-1)/(z+1)``; with ``prewarp_hz = f_w`` the map is
  ``s = w_w/tan(w_w T/2) (z-1)/(z+1)``, i.e. the bilinear map at the warped period
  ``T_w = 2 tan(w_w T/2)/w_w``, so that G_d(e^{j w_w T}) = G_c(j w_w) exactly
  (Franklin, Powell & Workman, Digital Control of Dynamic Systems, section 6.3.2);
* ``zoh`` -- the zero-order-hold (step-invariant) equivalent;
* ``foh`` -- the first-order-hold (ramp-invariant) equivalent.

For Werner 2021's ``G_c = b0/s`` on acceleration, Tustin gives
``F_k = F_{k-1} - b0 T/2 (a_k + a_{k-1})``, here ``b = b0 T/2 [1, 1]``,
``a = [1, -1]`` (the minus sign of negative feedback is applied by the block, not the filter).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.signal

from ..errors import ModelError
from ..settings import DISCRETIZATION_METHODS as METHODS
from .spec import ContinuousController


@dataclass(frozen=True, eq=False)
class DiscreteTf:
    """``G_d(z) = (b0 + b1 z^-1 + ...) / (1 + a1 z^-1 + ...)`` at period ``sample_period_s``."""

    b: np.ndarray
    a: np.ndarray
    sample_period_s: float
    method: str = "tustin"
    prewarp_hz: float | None = None
    feedback: str = "acceleration"

    def __post_init__(self):
        b = np.atleast_1d(np.asarray(self.b, dtype=float))
        a = np.atleast_1d(np.asarray(self.a, dtype=float))
        check_period(self.sample_period_s)
        for name, poly in (("b", b), ("a", a)):
            if poly.ndim != 1 or poly.size == 0 or not np.all(np.isfinite(poly)):
                raise ModelError(f"discrete filter coefficients {name} = {poly.tolist()} must be a "
                                 "non-empty list of finite numbers")
        if a[0] == 0.0:
            raise ModelError(f"discrete filter a[0] is zero (a = {a.tolist()}): the difference "
                             "equation is not causal -- give a[0] != 0")
        n = max(b.size, a.size)
        b = np.concatenate([b, np.zeros(n - b.size)]) / a[0]
        a = np.concatenate([a, np.zeros(n - a.size)]) / a[0]
        object.__setattr__(self, "b", b)
        object.__setattr__(self, "a", a)

    @property
    def order(self) -> int:
        return self.b.size - 1

    @property
    def sample_rate_hz(self) -> float:
        return 1.0 / self.sample_period_s

    def __call__(self, z) -> np.ndarray:
        """``G_d(z)`` at complex ``z`` (any shape)."""
        zi = 1.0 / np.asarray(z, dtype=complex)
        return np.polyval(self.b[::-1], zi) / np.polyval(self.a[::-1], zi)

    def frequency_response(self, w_rad_s) -> np.ndarray:
        """``G_d(e^{j w T})`` at angular frequencies ``w`` (rad/s)."""
        return self(np.exp(1j * np.asarray(w_rad_s, dtype=float) * self.sample_period_s))

    def scaled(self, factor: float) -> "DiscreteTf":
        """The same filter with its gain multiplied by ``factor`` (``b -> factor b``)."""
        return DiscreteTf(factor * self.b, self.a, self.sample_period_s, self.method,
                          self.prewarp_hz, self.feedback)

    def describe(self) -> str:
        """The coefficients, printable (full precision, so they can be copied into firmware)."""
        warp = f", prewarp {self.prewarp_hz:g} Hz" if self.prewarp_hz else ""
        fmt = lambda v: "[" + ", ".join(f"{x:.17g}" for x in v) + "]"  # noqa: E731
        return (f"G_d(z) on {self.feedback}, {self.method}{warp}, T = {self.sample_period_s:.6g} s "
                f"({self.sample_rate_hz:g} Hz):\n  b = {fmt(self.b)}\n  a = {fmt(self.a)}")


def check_period(sample_period_s) -> float:
    """A finite, positive sample period in seconds, or a ModelError naming the fix."""
    try:
        T = float(sample_period_s)
    except (TypeError, ValueError):
        raise ModelError(f"sample period must be a number in seconds (got {sample_period_s!r})") from None
    if not math.isfinite(T) or T <= 0.0:
        raise ModelError(f"sample period must be finite and > 0 s (got {sample_period_s}) -- "
                         "give a positive sample rate in Hz (e.g. 5000)")
    return T


def discretize_controller(ctrl: ContinuousController, sample_period_s: float,
                          method: str = "tustin", prewarp_hz: float | None = None) -> DiscreteTf:
    """The discrete filter of ``G_c(s)`` at period ``T`` (see the module docstring)."""
    T = check_period(sample_period_s)
    if method not in METHODS:
        raise ModelError(f"unknown discretisation method {method!r}; use one of " + ", ".join(METHODS))
    ctrl.require_proper("discretisation")
    T_design = T
    if prewarp_hz is not None:
        if method != "tustin":
            raise ModelError(f"prewarp_hz applies to the tustin method only (method is {method!r})"
                             " -- drop prewarp_hz or use method: tustin")
        f = float(prewarp_hz)
        nyquist = 0.5 / T
        if not math.isfinite(f) or f <= 0.0 or f >= nyquist:
            raise ModelError(f"prewarp frequency {prewarp_hz} Hz must lie in (0, {nyquist:g}) Hz, "
                             f"below the Nyquist frequency of the {1 / T:g} Hz sample rate -- "
                             "lower prewarp_hz or raise the sample rate")
        w = 2.0 * math.pi * f
        T_design = 2.0 * math.tan(w * T / 2.0) / w
    scipy_method = "bilinear" if method == "tustin" else method
    if ctrl.den.size == 1:         # static gain: every method gives the same number
        b, a = ctrl.num / ctrl.den, np.ones(1)
    else:
        bd, a, _ = scipy.signal.cont2discrete((ctrl.num, ctrl.den), T_design, method=scipy_method)
        b = np.atleast_2d(bd)[0]
    if not (np.all(np.isfinite(b)) and np.all(np.isfinite(a))):
        raise ModelError(f"{ctrl.describe()}: {method} discretisation at T = {T:g} s gave "
                         "non-finite coefficients -- check the controller's poles against T")
    return DiscreteTf(b, a, T, method, None if prewarp_hz is None else float(prewarp_hz),
                      ctrl.feedback)
