"""Continuous controller specifications G_c(s) (seed 000 eq. 6; seed 001 Table 1).

A foot controller applies ``f_a = -G_c(s) . s^k z_a`` (negative feedback, seed 000 eq. 7) to the
absolute vertical motion ``z_a`` of its foot, where ``k`` = 0, 1, 2 for displacement, velocity
and acceleration feedback. :class:`ContinuousController` holds ``G_c`` as polynomials in ``s``
(highest power first, as scipy.signal does) together with the feedback kind.

The *law on displacement* ``H(s) = s^k G_c(s)`` is what the continuous analyses use: its
polynomial part of degree <= 2 folds into M, D, C (seed 000 Figure 5, eq. 49) and its strictly
proper remainder needs controller states.

Ideal (improper) PD/PID controllers exist in the papers' continuous analyses; they can be built
with ``derivative_filter_s=None`` and used in the continuous frequency-domain and embedded
analyses, but anything that runs them in time refuses them (:meth:`require_proper`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..config import Section
from ..errors import ConfigError, ModelError

FEEDBACK_ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}
FEEDBACK_UNITS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}
STRUCTURES = ("P", "I", "PI", "PD", "PID", "lead_lag", "tf", "none")


def _trim(poly) -> np.ndarray:
    poly = np.atleast_1d(np.asarray(poly, dtype=float))
    nz = np.flatnonzero(poly)
    return poly[nz[0]:] if nz.size else np.zeros(1)


@dataclass(frozen=True, eq=False)
class ContinuousController:
    """``G_c(s) = num(s) / den(s)`` acting on a feedback kind; ``f = -G_c s^k z_a``."""

    num: np.ndarray
    den: np.ndarray
    feedback: str
    structure: str = "tf"
    gains: tuple[tuple[str, float], ...] = ()

    def __post_init__(self):
        if self.feedback not in FEEDBACK_ORDER:
            raise ModelError(f"unknown feedback kind {self.feedback!r}; use one of "
                             + ", ".join(FEEDBACK_ORDER))
        num, den = _trim(self.num), _trim(self.den)
        for name, poly in (("num", num), ("den", den)):
            if not np.all(np.isfinite(poly)):
                raise ModelError(f"controller {name} has a non-finite coefficient: {poly.tolist()}")
        if not np.any(den):
            raise ModelError("controller denominator is zero")
        object.__setattr__(self, "num", num)
        object.__setattr__(self, "den", den)

    # -- properties ---------------------------------------------------------------------------
    @property
    def order(self) -> int:
        """Derivative order k of the feedback signal (0, 1, 2)."""
        return FEEDBACK_ORDER[self.feedback]

    @property
    def is_proper(self) -> bool:
        return len(self.num) <= len(self.den)

    def require_proper(self, what: str) -> None:
        """Refuse an improper G_c where it must be realised as a causal filter."""
        if not self.is_proper:
            raise ModelError(
                f"{what}: the {self.structure} controller G_c(s) is improper (numerator degree "
                f"{len(self.num) - 1} > denominator degree {len(self.den) - 1}); an ideal "
                "derivative cannot run as a causal filter -- add a derivative filter pole "
                "(derivative_filter_s: e.g. 1/(2 pi 10 x the highest mode frequency))")

    def __call__(self, s) -> np.ndarray:
        """G_c evaluated at complex ``s`` (any shape)."""
        s = np.asarray(s, dtype=complex)
        return np.polyval(self.num, s) / np.polyval(self.den, s)

    def law(self, s) -> np.ndarray:
        """``H(s) = s^k G_c(s)``: force per unit foot *displacement* (with the minus sign
        of negative feedback applied by the caller)."""
        s = np.asarray(s, dtype=complex)
        return s**self.order * self(s)

    def law_split(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Split ``H = s^k G_c`` into ``h2 s^2 + h1 s + h0`` plus a strictly proper remainder
        (computed once per controller; see :attr:`_split`)."""
        return self._split

    @cached_property
    def _split(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Split ``H = s^k G_c`` into ``h2 s^2 + h1 s + h0`` plus a strictly proper remainder.

        Returns ``(h, rem_num, rem_den)`` with ``h = [h0, h1, h2]``; common factors of ``s``
        between remainder and denominator (an integrator meeting a differentiated signal, as in
        I control on acceleration) are cancelled exactly. Raises when the polynomial part has
        degree > 2 (seed 000 Figure 5's impossible cells: a force on jerk).
        """
        num = np.concatenate([self.num, np.zeros(self.order)])
        quot, rem = np.polydiv(num, self.den)
        quot = _trim(quot)
        if len(quot) > 3 and np.any(quot[:-3]):
            raise ModelError(
                f"{self.structure} on {self.feedback} gives a force law of degree "
                f"{len(quot) - 1} in s (a force on the jerk or higher) -- not representable in "
                "second-order form; add a derivative filter or change the feedback kind")
        h = np.zeros(3)
        tail = quot[-3:][::-1]
        h[: len(tail)] = tail
        den = self.den.copy()
        rem = _trim(rem)
        scale = max(np.abs(num).max(), 1.0)
        if np.all(np.abs(rem) <= 1e-14 * scale):
            return h, np.zeros(1), np.ones(1)
        while len(rem) > 1 and abs(rem[-1]) <= 1e-14 * scale and den[-1] == 0.0:
            rem, den = rem[:-1], den[:-1]
        return h, rem, den

    def describe(self) -> str:
        gains = ", ".join(f"{k}={v:g}" for k, v in self.gains)
        return f"{self.structure}({gains}) on {self.feedback}" if gains else (
            f"G_c = {np.array2string(self.num)}/{np.array2string(self.den)} on {self.feedback}")


# -- factories ---------------------------------------------------------------------------------
def _integrator_den(leak_hz: float | None) -> np.ndarray:
    """``s`` (pure integrator, the paper's) or ``s + 2 pi f_leak`` (leaky)."""
    return np.array([1.0, 2.0 * math.pi * leak_hz if leak_hz else 0.0])


def p_controller(kp: float, feedback: str) -> ContinuousController:
    return ContinuousController(np.array([kp]), np.array([1.0]), feedback, "P", (("kp", kp),))


def i_controller(ki: float, feedback: str, leak_hz: float | None = None) -> ContinuousController:
    """``K_I / s`` (or ``K_I / (s + 2 pi f_leak)``); on acceleration this is a skyhook damper."""
    return ContinuousController(np.array([ki]), _integrator_den(leak_hz), feedback, "I",
                                (("ki", ki),) + ((("leak_hz", leak_hz),) if leak_hz else ()))


def pi_controller(kp: float, ki: float, feedback: str,
                  leak_hz: float | None = None) -> ContinuousController:
    den = _integrator_den(leak_hz)
    return ContinuousController(np.polyadd(kp * den, [ki]), den, feedback, "PI",
                                (("kp", kp), ("ki", ki)) + ((("leak_hz", leak_hz),) if leak_hz else ()))


def pd_controller(kp: float, kd: float, feedback: str,
                  derivative_filter_s: float | None = None) -> ContinuousController:
    """``K_P + K_D s / (tau s + 1)``; ideal (improper) when ``derivative_filter_s`` is None."""
    gains = (("kp", kp), ("kd", kd))
    if derivative_filter_s is None:
        return ContinuousController(np.array([kd, kp]), np.array([1.0]), feedback, "PD", gains)
    tau = derivative_filter_s
    return ContinuousController(np.array([kp * tau + kd, kp]), np.array([tau, 1.0]), feedback,
                                "PD", gains + (("derivative_filter_s", tau),))


def pid_controller(kp: float, ki: float, kd: float, feedback: str,
                   derivative_filter_s: float | None = None,
                   leak_hz: float | None = None) -> ContinuousController:
    """``K_P + K_I / s + K_D s / (tau s + 1)`` (ideal derivative when tau is None)."""
    ig = _integrator_den(leak_hz)
    gains = (("kp", kp), ("ki", ki), ("kd", kd))
    if derivative_filter_s is None:
        num = np.polyadd(np.polymul([kd, kp], ig), [ki])
        return ContinuousController(num, ig, feedback, "PID", gains)
    tau = derivative_filter_s
    dfilt = np.array([tau, 1.0])
    num = np.polyadd(np.polyadd(kp * np.polymul(ig, dfilt), ki * dfilt), np.polymul([kd, 0.0], ig))
    return ContinuousController(num, np.polymul(ig, dfilt), feedback, "PID",
                                gains + (("derivative_filter_s", tau),))


def lead_lag_controller(gain: float, zero_hz: float, pole_hz: float,
                        feedback: str) -> ContinuousController:
    """``K (s / w_z + 1) / (s / w_p + 1)``: lead when the zero is below the pole."""
    wz, wp = 2 * math.pi * zero_hz, 2 * math.pi * pole_hz
    return ContinuousController(gain * np.array([1 / wz, 1.0]), np.array([1 / wp, 1.0]), feedback,
                                "lead_lag", (("gain", gain), ("zero_hz", zero_hz), ("pole_hz", pole_hz)))


CONTROLLER_KEYS = {
    "P": ("kp",), "I": ("ki",), "PI": ("kp", "ki"), "PD": ("kp", "kd"),
    "PID": ("kp", "ki", "kd"), "lead_lag": ("gain", "zero_hz", "pole_hz"), "tf": ("num", "den"),
}
OPTIONAL_KEYS = {"I": ("leak_hz",), "PI": ("leak_hz",), "PD": ("derivative_filter_s",),
                 "PID": ("derivative_filter_s", "leak_hz"), "lead_lag": (), "P": (), "tf": ()}


def controller_from_config(sec: Section, extra_keys: tuple[str, ...] = ()) -> ContinuousController | None:
    """Build a controller from a config mapping such as
    ``{type: I, feedback: acceleration, ki: 1.4e5}`` or ``{type: tf, num: [...], den: [...],
    feedback: velocity}``. ``type: none`` (or a missing ``type``) means no controller.

    ``extra_keys`` are keys a caller reads itself (limits, discretisation) and that are allowed
    here. Errors name the field and the fix.
    """
    kind = sec.choice("type", STRUCTURES, default="none")
    if kind == "none":
        sec.check_keys(("type", "feedback") + extra_keys)
        return None
    feedback = sec.choice("feedback", FEEDBACK_ORDER)
    required = CONTROLLER_KEYS[kind]
    optional = OPTIONAL_KEYS[kind]
    sec.check_keys(("type", "feedback") + required + optional + extra_keys)
    try:
        if kind == "tf":
            num = sec.number_list("num", min_length=1, nonempty_leading=True)
            den = sec.number_list("den", min_length=1, nonempty_leading=True)
            return ContinuousController(np.array(num), np.array(den), feedback, "tf")
        g = {k: sec.number(k) for k in required}
        leak = sec.number("leak_hz", None, positive=True, unit="Hz") if sec.has("leak_hz") else None
        tau = (sec.number("derivative_filter_s", positive=True, unit="s")
               if sec.has("derivative_filter_s") else None)
        if kind == "P":
            return p_controller(g["kp"], feedback)
        if kind == "I":
            return i_controller(g["ki"], feedback, leak)
        if kind == "PI":
            return pi_controller(g["kp"], g["ki"], feedback, leak)
        if kind == "PD":
            return pd_controller(g["kp"], g["kd"], feedback, tau)
        if kind == "PID":
            return pid_controller(g["kp"], g["ki"], g["kd"], feedback, tau, leak)
        for key in ("zero_hz", "pole_hz"):
            if g[key] <= 0:
                raise sec.error(key, f"must be > 0 (got {g[key]})", fix="give a frequency in Hz")
        return lead_lag_controller(g["gain"], g["zero_hz"], g["pole_hz"], feedback)
    except ModelError as exc:
        raise ConfigError(sec.path, str(exc), source=sec.source) from None
