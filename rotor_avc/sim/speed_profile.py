"""Rotor speed over time: constant, linear run-up/run-down, stepped speeds with dwell, sequences.

Every profile is piecewise linear in time, given by knots ``(t_i, Omega_i)``; a jump (two knots
at the same time) is allowed and takes effect at its instant (right-continuous). From the knots::

    Omega(t)   linear between knots (rad/s)
    Omega'(t)  the slope of the segment holding t (rad/s^2; 0 at a jump -- the tangential
               impulse of an instantaneous speed change is not modelled)
    theta(t)   = int_0^t Omega dt, exact (piecewise quadratic, continuous)

After the last knot the speed is held. Configs give speeds as rotational frequencies in Hz
(``speed_hz``, the papers' f_r); everything inside is rad/s.

Config forms (``simulation.speed``), one settings class per ``type`` (:data:`PROFILE_SETTINGS`
declares every key; unknown keys refused)::

    {type: constant, speed_hz: 50.0, duration_s: 2.0}        # duration optional
    {type: ramp, start_hz: 0.0, stop_hz: 250.0, duration_s: 25.0}   # or rate_hz_per_s
    {type: stepped, speeds_hz: [10, 20, 40], dwell_s: 2.0, transition_s: 0.1}
    {type: sequence, parts: [<any of the above>, ...]}       # played one after the other
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from ..section import Section
from ..errors import ModelError
from ..settings import read_settings, setting

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, eq=False)
class SpeedProfile:
    """Piecewise-linear speed through knots ``times_s`` (non-decreasing) and ``speeds_rad_s``.

    ``length_s`` is the profile's natural duration (None: it holds its last speed for ever, e.g.
    a constant speed without a duration)."""

    times_s: np.ndarray
    speeds_rad_s: np.ndarray
    length_s: float | None = None

    def __post_init__(self):
        t = np.atleast_1d(np.asarray(self.times_s, dtype=float))
        w = np.atleast_1d(np.asarray(self.speeds_rad_s, dtype=float))
        if t.shape != w.shape or t.ndim != 1 or t.size == 0:
            raise ModelError("speed profile: times and speeds must be 1-D of equal length")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(w))):
            raise ModelError("speed profile: times and speeds must be finite")
        if t[0] != 0.0 or np.any(np.diff(t) < 0):
            raise ModelError("speed profile: knot times must start at 0 and not decrease")
        if np.any(w < 0):
            raise ModelError("speed profile: speeds must be >= 0 (the models' direction of "
                             "rotation is fixed)")
        object.__setattr__(self, "times_s", t)
        object.__setattr__(self, "speeds_rad_s", w)
        # angle at every knot: trapezoid per segment (exact for linear speed)
        theta = np.concatenate([[0.0], np.cumsum(np.diff(t) * 0.5 * (w[1:] + w[:-1]))])
        object.__setattr__(self, "_knot_angles", theta)

    # -- scalar summaries ----------------------------------------------------------------------
    @property
    def max_speed_rad_s(self) -> float:
        return float(self.speeds_rad_s.max())

    @property
    def min_speed_rad_s(self) -> float:
        return float(self.speeds_rad_s.min())

    def held_speeds(self) -> np.ndarray:
        """Speeds held constant over a segment of positive length (or after the last knot)."""
        t, w = self.times_s, self.speeds_rad_s
        flat = (np.diff(t) > 0) & (np.diff(w) == 0)
        return np.unique(np.concatenate([w[:-1][flat], w[-1:]]))

    # -- evaluation ----------------------------------------------------------------------------
    def sample(self, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(Omega, Omega', theta)`` at times ``t_s`` (array, >= 0), right-continuous at jumps."""
        t = np.asarray(t_s, dtype=float)
        knots, w = self.times_s, self.speeds_rad_s
        i = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, knots.size - 1)
        dt = t - knots[i]
        nxt = np.minimum(i + 1, knots.size - 1)
        span = knots[nxt] - knots[i]
        slope = np.where(span > 0, (w[nxt] - w[i]) / np.where(span > 0, span, 1.0), 0.0)
        speed = w[i] + slope * dt
        angle = self._knot_angles[i] + w[i] * dt + 0.5 * slope * dt * dt
        return speed, slope, angle


# -- factories ---------------------------------------------------------------------------------
def constant_speed(speed_rad_s: float, duration_s: float | None = None) -> SpeedProfile:
    return SpeedProfile(np.array([0.0]), np.array([float(speed_rad_s)]), duration_s)


def ramp(start_rad_s: float, stop_rad_s: float, duration_s: float) -> SpeedProfile:
    """Linear run-up (stop > start) or run-down over ``duration_s``, then held."""
    if not duration_s > 0:
        raise ModelError(f"ramp duration must be > 0 (got {duration_s})")
    return SpeedProfile(np.array([0.0, duration_s]), np.array([start_rad_s, stop_rad_s]),
                        duration_s)


def stepped(speeds_rad_s, dwell_s: float, transition_s: float = 0.0) -> SpeedProfile:
    """Dwell ``dwell_s`` at each speed, moving linearly between them in ``transition_s``
    (0: jump). Total length ``n dwell + (n - 1) transition``."""
    speeds = [float(w) for w in speeds_rad_s]
    if not speeds or not dwell_s > 0 or transition_s < 0:
        raise ModelError("stepped speeds need at least one speed, dwell_s > 0, transition_s >= 0")
    times, values, t = [], [], 0.0
    for k, w in enumerate(speeds):
        if k:
            t += transition_s
        times += [t, t + dwell_s]
        values += [w, w]
        t += dwell_s
    return SpeedProfile(np.array(times), np.array(values), t)


def sequence(parts: list[SpeedProfile]) -> SpeedProfile:
    """Parts played one after the other; every part but the last needs a length (a part whose
    last knot comes before its length holds that speed until the next part starts)."""
    times, values, t = [], [], 0.0
    for k, part in enumerate(parts):
        if part.length_s is None and k < len(parts) - 1:
            raise ModelError("only the last part of a sequence may be open-ended "
                             "(give the others a duration_s)")
        times.append(part.times_s + t)
        values.append(part.speeds_rad_s)
        if part.length_s is not None and part.length_s > part.times_s[-1]:
            times.append(np.array([t + part.length_s]))
            values.append(part.speeds_rad_s[-1:])
        if part.length_s is not None:
            t += part.length_s
    length = None if parts[-1].length_s is None else t
    return SpeedProfile(np.concatenate(times), np.concatenate(values), length)


# -- config ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ConstantProfile:
    """``{type: constant}``: one speed, held."""

    type: str = setting(doc="`constant`", choices=("constant",))
    speed_hz: float = setting(doc="rotational frequency f_r", unit="Hz", nonnegative=True)
    duration_s: float | None = setting(None, "length of the profile (none: held for ever)",
                                       unit="s", positive=True)

    def profile(self) -> SpeedProfile:
        return constant_speed(TWO_PI * self.speed_hz, self.duration_s)


@dataclass(frozen=True)
class RampProfile:
    """``{type: ramp}``: a linear run-up or run-down (the constant angular acceleration of Zhou &
    Shi 2001's balancing run-up), then held; its length given directly or as a rate."""

    type: str = setting(doc="`ramp`", choices=("ramp",))
    start_hz: float = setting(doc="rotational frequency at t = 0", unit="Hz", nonnegative=True)
    stop_hz: float = setting(doc="rotational frequency at the end (!= start_hz)", unit="Hz",
                             nonnegative=True)
    duration_s: float | None = setting(None, "length of the ramp (or rate_hz_per_s)", unit="s",
                                       positive=True)
    rate_hz_per_s: float | None = setting(None, "rate of change of f_r (or duration_s)",
                                          unit="Hz/s", positive=True)

    def check(self, sec: Section) -> None:
        if (self.duration_s is None) == (self.rate_hz_per_s is None):
            raise sec.error("duration_s", "give exactly one of duration_s and rate_hz_per_s",
                            fix="e.g. `duration_s: 20.0` or `rate_hz_per_s: 10.0`")
        if self.start_hz == self.stop_hz:
            raise sec.error("stop_hz", "equals start_hz", fix="use `type: constant` for a "
                                                              "constant speed")

    def profile(self) -> SpeedProfile:
        start, stop = TWO_PI * self.start_hz, TWO_PI * self.stop_hz
        dur = (self.duration_s if self.duration_s is not None
               else abs(stop - start) / (TWO_PI * self.rate_hz_per_s))
        return ramp(start, stop, dur)


@dataclass(frozen=True)
class SteppedProfile:
    """``{type: stepped}``: a dwell at each speed, moving linearly between them (0 s: a jump)."""

    type: str = setting(doc="`stepped`", choices=("stepped",))
    speeds_hz: tuple[float, ...] = setting(doc="rotational frequencies, in order (>= 0)",
                                           unit="Hz", min_length=1)
    dwell_s: float = setting(doc="time held at each speed", unit="s", positive=True)
    transition_s: float = setting(0.0, "time from one speed to the next", unit="s",
                                  nonnegative=True)

    def check(self, sec: Section) -> None:
        if min(self.speeds_hz) < 0:
            raise sec.error("speeds_hz", f"speeds must be >= 0 (got {list(self.speeds_hz)})",
                            fix="give rotational frequencies >= 0 Hz")

    def profile(self) -> SpeedProfile:
        return stepped([TWO_PI * f for f in self.speeds_hz], self.dwell_s, self.transition_s)


@dataclass(frozen=True)
class SequenceProfile:
    """``{type: sequence}``: profiles played one after the other (:func:`sequence`).

    ``parts`` is a list of profile mappings, each validated by the class of its ``type``
    (:func:`profile_from_config`): the settings reader holds no lists of sections."""

    type: str = setting(doc="`sequence`", choices=("sequence",))
    parts: tuple[dict, ...] = setting(doc="profiles of the other types, in order; every one but "
                                      "the last with a length", min_length=1)


#: the class declaring each profile ``type`` (every key, ``type`` included)
PROFILE_SETTINGS = {"constant": ConstantProfile, "ramp": RampProfile, "stepped": SteppedProfile,
                    "sequence": SequenceProfile}


def profile_from_config(sec: Section) -> SpeedProfile:
    """Build a profile from ``simulation.speed`` (see the module docstring), validated by the
    class :data:`PROFILE_SETTINGS` declares for its ``type``."""
    kind = sec.choice("type", PROFILE_SETTINGS)
    if kind == "sequence":
        return _sequence_from_config(sec)
    return read_settings(PROFILE_SETTINGS[kind], sec).profile()


def _sequence_from_config(sec: Section) -> SpeedProfile:
    """``{type: sequence, parts: [...]}``: :class:`SequenceProfile`'s keys, each part read by
    :func:`profile_from_config`."""
    sec.check_keys(f.name for f in fields(SequenceProfile))
    raw = sec.raw("parts")
    if not isinstance(raw, list) or not raw:
        raise sec.error("parts", "must be a non-empty list of profiles",
                        fix="e.g. `parts: [{type: constant, speed_hz: 10, duration_s: 1}, ...]`")
    parts = []
    for k, item in enumerate(raw):
        if not isinstance(item, dict):
            raise sec.error(f"parts[{k}]", "must be a mapping such as {type: ramp, ...}")
        part_sec = Section(item, f"{sec.path}.parts[{k}]", sec.source)
        if part_sec.raw("type", None) == "sequence":
            raise part_sec.error("type", "sequences do not nest", fix="flatten the parts")
        part = profile_from_config(part_sec)
        if part.length_s is None and k < len(raw) - 1:
            raise part_sec.error("duration_s", "missing: only the last part may be open-ended",
                                 fix="give this part a duration_s")
        parts.append(part)
    return sequence(parts)
