"""Actuator limits and anti-windup around an :class:`~rotor_avc.control.filter.IirFilter`.

Limits act on the filter output ``y = G_c * signal`` (the force is ``-y``; the limits are
symmetric, so limiting ``y`` limits the force): saturation ``|y| <= force_limit_n``, then an
optional rate limit ``|y_k - y_{k-1}| <= rate_limit_n_per_s * T``.

Anti-windup strategies carry the names of ros-controls ``control_toolbox::AntiWindupStrategy``:

* ``back_calculation`` -- control_toolbox's ``i_term += dt (ki e + (u_sat - u)/trk_tc)``. Here the
  recursion of the whole filter is fed ``y + K_b T (y_sat - y)`` instead of ``y`` (with
  ``K_b = back_calculation_gain = 1/trk_tc``, ``0 < K_b T <= 1``); for a ZOH PI this is exactly
  ``I_{k+1} = I_k + T ki e_k + K_b T (u_sat - u)``, and for any controller it is the observer
  (Aström-Wittenmark) form of back-calculation. Promise: the stored state stays within
  about ``ki e / K_b`` of the value that just reaches the limit, so after the error reverses the
  output leaves saturation within about ``trk_tc = 1/K_b`` (plus one sample), however long it
  was saturated.
* ``conditional_integration`` -- control_toolbox integrates only if ``u == u_sat`` or
  ``e u <= 0``. Here: while the output is limited, a state update that would push the output
  further into the limit is skipped (the state is frozen). Promise: the state never exceeds
  the value that reached the limit by more than one sample's increment, so the output leaves
  saturation within two samples after the error reverses.
* ``none`` -- the filter runs unlimited inside; recovery takes as long as the excess built up.

The linear analyses (``rotor_avc.analysis.sampled_loop``) do not see limits: they hold while no
limit is active.
"""
from __future__ import annotations

import math

from ..errors import ModelError
from .filter import IirFilter

ANTI_WINDUP = ("none", "back_calculation", "conditional_integration")


class OutputLimits:
    """Saturation ``|y| <= force_limit_n`` and rate limit ``|dy| <= rate_limit_n_per_s T``."""

    __slots__ = ("force_limit_n", "max_step_n", "last")

    def __init__(self, sample_period_s: float, force_limit_n: float | None = None,
                 rate_limit_n_per_s: float | None = None):
        for name, value in (("force_limit_n", force_limit_n),
                            ("rate_limit_n_per_s", rate_limit_n_per_s)):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise ModelError(f"{name} must be finite and > 0 (got {value}) -- leave it out "
                                 "for no limit")
        self.force_limit_n = math.inf if force_limit_n is None else float(force_limit_n)
        self.max_step_n = (math.inf if rate_limit_n_per_s is None
                           else float(rate_limit_n_per_s) * sample_period_s)
        self.last = 0.0

    @property
    def active(self) -> bool:
        return self.force_limit_n < math.inf or self.max_step_n < math.inf

    def reset(self, output: float = 0.0) -> None:
        """Set the previous output (the rate limit's reference)."""
        self.last = float(output)

    def apply(self, y: float) -> float:
        lim = self.force_limit_n
        if y > lim:
            y = lim
        elif y < -lim:
            y = -lim
        step = self.max_step_n
        last = self.last
        if y - last > step:
            y = last + step
        elif last - y > step:
            y = last - step
        self.last = y
        return y


def check_anti_windup(anti_windup: str, limits: OutputLimits, sample_period_s: float,
                      back_calculation_gain: float | None) -> float:
    """Validate the strategy; returns the per-sample back-calculation factor ``K_b T``."""
    if anti_windup not in ANTI_WINDUP:
        raise ModelError(f"unknown anti_windup {anti_windup!r}; use one of " + ", ".join(ANTI_WINDUP))
    if anti_windup != "none" and not limits.active:
        raise ModelError(f"anti_windup {anti_windup!r} needs a limit to act on -- give "
                         "force_limit_n (or rate_limit_n_per_s), or set anti_windup: none")
    if back_calculation_gain is not None and anti_windup != "back_calculation":
        raise ModelError("back_calculation_gain is only used with anti_windup: back_calculation")
    if anti_windup != "back_calculation":
        return 0.0
    if back_calculation_gain is None:
        return 1.0                      # trk_tc = T: track the limit within one sample
    kb = float(back_calculation_gain) * sample_period_s
    if not (math.isfinite(kb) and 0.0 < kb <= 1.0):
        raise ModelError(
            f"back_calculation_gain must lie in (0, {1 / sample_period_s:g}] 1/s, i.e. the "
            f"tracking time constant 1/K_b at least one sample (got {back_calculation_gain}) -- "
            "lower it (1/K_b ~ the integral time is the usual choice)")
    return kb


def limited_step(filt: IirFilter, x: float, limits: OutputLimits, anti_windup: str,
                 kb: float) -> float:
    """One sample through filter, limits and anti-windup; returns the applied output."""
    y = filt.output(x)
    y_lim = limits.apply(y)
    if y_lim == y or anti_windup == "none":
        filt.advance(x, y)
    elif anti_windup == "back_calculation":
        filt.advance(x, y + kb * (y_lim - y))
    else:                                             # conditional_integration
        new = filt.next_state(x, y)
        if not filt.n or (new[0] - filt.z[0]) * (y - y_lim) <= 0.0:
            filt.z = new
    return y_lim
