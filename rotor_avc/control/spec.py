"""Continuous controller specifications G_c(s) (Werner 2021 eq. 6; Werner 2019 Table 1) and the
declaration of a ``controllers:`` entry (:class:`ControllerSettings`).

A foot controller applies ``f_a = -G_c(s) . s^k z_a`` (negative feedback, Werner 2021 eq. 7) to the
absolute vertical motion ``z_a`` of its foot, where ``k`` = 0, 1, 2 for displacement, velocity
and acceleration feedback. :class:`ContinuousController` holds ``G_c`` as polynomials in ``s``
(highest power first, as scipy.signal does) together with the feedback kind.

The *law on displacement* ``H(s) = s^k G_c(s)`` is what the continuous analyses use: its
polynomial part of degree <= 2 folds into M, D, C (Werner 2021 Figure 5, eq. 49) and its strictly
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

from ..section import Section
from ..errors import ModelError
from ..settings import read_part, read_settings, setting
from .limits import ANTI_WINDUP

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
        degree > 2 (Werner 2021 Figure 5's impossible cells: a force on jerk).
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
    "none": (),
}
OPTIONAL_KEYS = {"I": ("leak_hz",), "PI": ("leak_hz",), "PD": ("derivative_filter_s",),
                 "PID": ("derivative_filter_s", "leak_hz"), "lead_lag": (), "P": (), "tf": (),
                 "none": ()}
#: keys of the digital block (:mod:`rotor_avc.control.block`), allowed next to every structure
BLOCK_KEYS = ("force_limit_n", "rate_limit_n_per_s", "anti_windup", "back_calculation_gain",
              "delay_samples", "measurement_limit")
#: default plausible range ``|signal| <= measurement_limit`` per feedback kind (SI): far beyond
#: what a foot of a running machine sees (1 m; 100 m/s; 1e5 m/s^2 = 10,000 g, beyond most
#: accelerometers' range), so only a broken sensor or a corrupted message gets there
PLAUSIBLE_LIMITS = {"displacement": 1.0, "velocity": 100.0, "acceleration": 1.0e5}

_PER_KIND = "on displacement, velocity, acceleration feedback"
_PLAUSIBLE = ", ".join(f"{v:g} {FEEDBACK_UNITS[k]}" for k, v in PLAUSIBLE_LIMITS.items())


# -- the ``controllers:`` section ---------------------------------------------------------------
@dataclass(frozen=True)
class ControllerSettings:
    """``controllers.<actuator id>``: one actuator's ``G_c(s)`` (Werner 2021 eq. 6; Werner 2019
    Table 1) and the digital block that runs it (:mod:`rotor_avc.control.block`).

    The force is ``f_a = -G_c(s) s^k z_a`` (Werner 2021 eq. 7), so the unit of ``G_c`` and of its
    gains depends on the feedback kind: N per unit of the measured signal (m, m/s or m/s^2).
    Which gains a structure needs: :data:`CONTROLLER_KEYS` (:data:`OPTIONAL_KEYS` may be added).
    ``leak_hz``, ``derivative_filter_s``, ``lead_lag`` and the block's keys are additions of this
    package (the papers' controllers are ideal and continuous).
    """

    type: str = setting("none", "structure of G_c(s) (Werner 2019 Table 1; `tf`: the general "
                        "num/den of Werner 2021 eq. 6); `none`: no controller (the block's keys "
                        "are still checked)", choices=STRUCTURES)
    feedback: str | None = setting(None, "the measured foot signal: z_a, s z_a or s^2 z_a "
                                   "(Werner 2021 eq. 7, k = 0, 1, 2); required unless type none",
                                   choices=tuple(FEEDBACK_ORDER))
    kp: float | None = setting(None, f"proportional gain K_P (P, PI, PD, PID): N/m, N s/m, kg "
                               f"{_PER_KIND}")
    ki: float | None = setting(None, f"integral gain K_I, G_c = K_I/s (I, PI, PID): N/(m s), N/m, "
                               f"N s/m {_PER_KIND}")
    kd: float | None = setting(None, f"derivative gain K_D, G_c = K_D s (PD, PID): N s/m, kg, "
                               f"N s^3/m {_PER_KIND}")
    leak_hz: float | None = setting(None, "I, PI, PID: leaky integrator 1/(s + 2 pi leak_hz) "
                                    "instead of 1/s", unit="Hz", positive=True)
    derivative_filter_s: float | None = setting(None, "PD, PID: derivative K_D s/(tau s + 1); "
                                                "without it the ideal (improper) K_D s",
                                                unit="s", positive=True)
    gain: float | None = setting(None, f"lead_lag: K of K (s/w_z + 1)/(s/w_p + 1): N/m, N s/m, "
                                 f"kg {_PER_KIND}")
    zero_hz: float | None = setting(None, "lead_lag: zero w_z/(2 pi)", unit="Hz", positive=True)
    pole_hz: float | None = setting(None, "lead_lag: pole w_p/(2 pi)", unit="Hz", positive=True)
    num: tuple[float, ...] | None = setting(None, "tf: numerator of G_c(s), highest power of s "
                                            "first (G_c in N/m, N s/m, kg " + _PER_KIND + ")",
                                            min_length=1)
    den: tuple[float, ...] | None = setting(None, "tf: denominator of G_c(s), highest power of s "
                                            "first", min_length=1)
    force_limit_n: float | None = setting(None, "the force is saturated at +-limit (none: no limit)",
                                          unit="N", positive=True)
    rate_limit_n_per_s: float | None = setting(None, "largest rate of change of the force (none: "
                                               "no limit)",
                                               unit="N/s", positive=True)
    anti_windup: str | None = setting(None, "default: `back_calculation` with a force or rate "
                                      "limit, else `none` (rotor_avc/control/limits.py)",
                                      choices=ANTI_WINDUP)
    back_calculation_gain: float | None = setting(None, "K_b = 1/tracking time constant of "
                                                  "`back_calculation`, at most the sample rate "
                                                  "(default: the sample rate)", unit="1/s",
                                                  positive=True)
    delay_samples: int = setting(0, "extra delay of the measured signal, in samples", minimum=0,
                                 maximum=1000)
    measurement_limit: float | None = setting(None, "a measurement beyond +-limit is rejected: "
                                              f"m, m/s, m/s^2 {_PER_KIND} (default "
                                              f"{_PLAUSIBLE})", positive=True)

    def check(self, sec: Section) -> None:
        needed = CONTROLLER_KEYS[self.type]
        sec.check_keys(("type", "feedback") + needed + OPTIONAL_KEYS[self.type] + BLOCK_KEYS)
        for key in (("feedback",) + needed if self.type != "none" else ()):
            if getattr(self, key) is None:
                raise sec.error(key, "missing", fix=f"add `{key}:` to {sec.path} (type "
                                f"{self.type} needs " + ", ".join(("feedback",) + needed) + ")")
        if self.type == "tf":
            for key in ("num", "den"):
                sec.number_list(key, nonempty_leading=True)      # refuses a leading zero

    def continuous(self) -> ContinuousController | None:
        """This entry's ``G_c(s)`` (``None`` for type none)."""
        fb, leak, tau = self.feedback, self.leak_hz, self.derivative_filter_s
        if self.type == "none":
            return None
        if self.type == "tf":
            return ContinuousController(np.array(self.num), np.array(self.den), fb, "tf")
        if self.type == "P":
            return p_controller(self.kp, fb)
        if self.type == "I":
            return i_controller(self.ki, fb, leak)
        if self.type == "PI":
            return pi_controller(self.kp, self.ki, fb, leak)
        if self.type == "PD":
            return pd_controller(self.kp, self.kd, fb, tau)
        if self.type == "PID":
            return pid_controller(self.kp, self.ki, self.kd, fb, tau, leak)
        return lead_lag_controller(self.gain, self.zero_hz, self.pole_hz, fb)


#: the declaration of one ``controllers:`` entry (for the configuration reference and schemas)
CONTROLLER_SETTINGS = ControllerSettings


@dataclass(frozen=True)
class MachineControllers:
    """The top-level ``controllers:`` key of a machine config: an entry per actuator id."""

    controllers: dict[str, ControllerSettings] | None = setting(
        None, "G_c(s) and digital block per actuator id (none: all loops open)")


def controller_settings(cfg: Section) -> dict[str, ControllerSettings]:
    """``controllers:`` of a machine config, validated: actuator id -> its entry (config order)."""
    return read_part(MachineControllers, cfg).controllers or {}


def controller_from_config(sec: Section) -> ContinuousController | None:
    """The ``G_c(s)`` of one entry such as ``{type: I, feedback: acceleration, ki: 1.4e5}`` or
    ``{type: tf, num: [...], den: [...], feedback: velocity}``, validated as a
    :class:`ControllerSettings` (errors name the field and the fix); ``None`` for type none."""
    return read_settings(ControllerSettings, sec).continuous()
