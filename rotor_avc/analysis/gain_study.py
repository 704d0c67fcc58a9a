"""Gain studies: forced response over speed for a family of controller gains (Werner 2019 Sec. 4).

For each gain ``K`` of one controller term (the paper: P-controllers, ``K_pL = K_pR``, on
displacement, velocity or acceleration feedback; eqs. 79-84) every actuator gets the same
controller and the synchronous response to one excitation is computed over speed (eqs. 65-77,
:func:`rotor_avc.closed_loop.frf.unbalance_frf`). From the curves:

* **resonances** -- the open-loop peaks of the chosen quantities (default: the bearing-housing
  velocities, the paper's Figs. 5, 8, 11) whose height is at least ``peak_fraction`` of that
  curve's maximum, followed over the gains: at each gain the
  curve's peaks (again at least ``peak_fraction`` of its maximum, located by parabolic
  interpolation between speed points) are assigned one-to-one to the followed resonances by the
  smallest speed shift; a resonance without a peak (flattened by damping, or moved out of the
  speed range) is NaN at that gain. With coarse gain steps a flattened peak may be followed to a
  neighbouring one: finer steps make the following reliable;
* **reductions** of each resonance (the paper does not define how it measures them): (A) the
  controlled maximum within ``+-window`` of the open-loop peak speed against the open-loop peak,
  and (B) both curves at the open-loop peak speed, in percent;
* **actuator forces**: the largest force amplitude over speed per actuator.

Amplitudes are per unit excitation amplitude in SI (e.g. (m/s)/m for the bent rotor). The
gains run on the study engine (:mod:`rotor_avc.studies`), one point per gain.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.optimize
from scipy.signal import find_peaks

from ..section import Section
from ..control.spec import CONTROLLER_KEYS, ContinuousController, controller_from_config
from ..errors import ModelError
from ..models.plant import LinearPlant
from ..closed_loop.frf import unbalance_frf
from ..closed_loop.loop import ClosedLoop
from ..studies.engine import StudySpec, run_study
from ..studies.points import ValueList

RPM_PER_RAD_S = 30.0 / np.pi
#: the swept gain of each controller structure unless named otherwise
DEFAULT_SWEEP = {"P": "kp", "I": "ki", "PI": "kp", "PD": "kp", "PID": "kp"}


@dataclass
class Resonance:
    """One followed peak: ``quantity`` (e.g. ``bearing_vy``), its speed and height per gain."""

    quantity: str
    speed_rpm: np.ndarray
    amplitude: np.ndarray
    reduction_window_pct: np.ndarray
    reduction_same_speed_pct: np.ndarray

    @property
    def label(self) -> str:
        return f"{self.quantity}@{self.speed_rpm[0]:.0f}rpm"


@dataclass
class GainStudy:
    """Responses of one gain sweep: ``curves[q][i]`` is ``|q|`` over ``speed_rpm`` at
    ``gains[i]`` (``gains[0] = 0``: the open loop)."""

    feedback: str
    structure: str
    gain_name: str
    gains: np.ndarray
    excitation: str
    speed_rpm: np.ndarray
    curves: dict[str, np.ndarray]
    units: dict[str, str]
    resonances: list[Resonance] = field(default_factory=list)

    def max_force(self, quantity: str) -> tuple[np.ndarray, np.ndarray]:
        """Largest amplitude of ``quantity`` over speed per gain, and its speed (rpm)."""
        c = self.curves[quantity]
        return c.max(axis=1), self.speed_rpm[np.argmax(c, axis=1)]


def study_controller(structure: str, feedback: str, gain_name: str, value: float,
                     fixed: dict[str, float]) -> ContinuousController:
    """The controller of one sweep point: ``structure`` with ``gain_name = value`` and the other
    gains from ``fixed`` (validated like a config entry)."""
    if structure not in DEFAULT_SWEEP:
        raise ModelError(f"gain studies sweep P, I, PI, PD or PID controllers (got {structure!r})")
    keys = CONTROLLER_KEYS[structure]
    if gain_name not in keys:
        raise ModelError(f"a {structure} controller has no gain {gain_name!r}; its gains: "
                         + ", ".join(keys))
    unknown = set(fixed) - set(keys) - {"leak_hz", "derivative_filter_s"}
    if unknown:
        raise ModelError(f"fixed gains {sorted(unknown)} do not belong to a {structure} controller")
    missing = [k for k in keys if k != gain_name and k not in fixed]
    if missing:
        raise ModelError(f"a {structure} sweep over {gain_name} needs fixed values for "
                         + ", ".join(missing))
    data = {"type": structure, "feedback": feedback, **fixed, gain_name: float(value)}
    return controller_from_config(Section(data, "study"))


def _peaks(curve: np.ndarray, speeds: np.ndarray, fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """Peak speeds and heights (parabolic interpolation) of peaks >= ``fraction`` x max."""
    idx, _ = find_peaks(curve, height=fraction * curve.max())
    a, b, c = curve[idx - 1], curve[idx], curve[idx + 1]
    den = a - 2 * b + c
    shift = np.where(den != 0, 0.5 * (a - c) / np.where(den != 0, den, 1.0), 0.0)
    step = speeds[idx + 1] - speeds[idx]
    return speeds[idx] + shift * step, b - 0.25 * (a - c) * shift


def _follow(curves: np.ndarray, speeds: np.ndarray, fraction: float) -> list[tuple]:
    """Speeds and heights of the open-loop peaks of ``curves`` (gains x speeds), followed over
    the gains by one-to-one nearest assignment (see the module docstring)."""
    start, height = _peaks(curves[0], speeds, fraction)
    where = np.full((len(start), len(curves)), np.nan)
    amp = np.full_like(where, np.nan)
    where[:, 0], amp[:, 0] = start, height
    last = start.copy()
    for i in range(1, len(curves)):
        pk, h = _peaks(curves[i], speeds, fraction)
        if pk.size == 0 or start.size == 0:
            continue
        rows, cols = scipy.optimize.linear_sum_assignment(np.abs(last[:, None] - pk[None, :]))
        where[rows, i], amp[rows, i] = pk[cols], h[cols]
        last[rows] = pk[cols]
    return list(zip(where, amp))


@dataclass(frozen=True)
class GainCurves:
    """Study evaluator: ``{quantity: (|response| over speed, unit)}`` with the controller of one
    gain on every actuator (gain 0: the loop open)."""

    plant: LinearPlant
    feedback: str
    structure: str
    gain_name: str
    fixed: dict
    speed_rad_s: np.ndarray
    excitation: str
    fields = None                    # arrays: an in-memory study

    def prepare(self) -> LinearPlant:
        return self.plant

    def evaluate(self, plant: LinearPlant, point) -> dict:
        value = point.values[self.gain_name]
        ctrls = {} if value == 0.0 else {
            a.id: study_controller(self.structure, self.feedback, self.gain_name, value, self.fixed)
            for a in plant.actuators}
        frf = unbalance_frf(ClosedLoop(plant, ctrls), self.speed_rad_s, [self.excitation])
        return {quantity: (np.abs(frf.responses[key]), frf.units[key])
                for key, (quantity, _) in frf.parts.items()}

    def describe(self) -> dict:
        return {"gain_curves": [self.plant.name, self.feedback, self.structure, self.gain_name,
                                self.fixed, self.speed_rad_s.tolist(), self.excitation]}


def gain_study(plant: LinearPlant, feedback: str, gains, speed_rpm, excitation: str,
               structure: str = "P", gain_name: str | None = None, fixed: dict | None = None,
               window_rpm: float = 200.0, peak_fraction: float = 0.25,
               resonance_quantities=None, backend=None, batch_size=None) -> GainStudy:
    """Sweep one controller gain on every actuator of ``plant`` (see the module docstring) on
    the study engine (``backend``, ``batch_size``: :func:`rotor_avc.studies.engine.run_study`)."""
    gains = np.asarray(gains, float)
    speeds = np.asarray(speed_rpm, float)
    if gains.ndim != 1 or gains.size == 0 or np.any(~np.isfinite(gains)):
        raise ModelError("study gains must be a non-empty list of finite numbers")
    if speeds.ndim != 1 or speeds.size < 5 or np.any(np.diff(speeds) <= 0) or speeds[0] <= 0:
        raise ModelError("study speeds must be at least 5 ascending speeds > 0 rpm")
    if not plant.actuators:
        raise ModelError(f"{plant.name} has no actuators to control")
    gain_name = gain_name or DEFAULT_SWEEP.get(structure, "kp")
    gains = np.concatenate([[0.0], gains[gains != 0.0]])
    if gains.size > 1:                           # a bad controller fails here, not per point
        study_controller(structure, feedback, gain_name, gains[-1], fixed or {})
    evaluator = GainCurves(plant, feedback, structure, gain_name, fixed or {},
                           speeds / RPM_PER_RAD_S, excitation)
    run = run_study(StudySpec(ValueList(gain_name, gains), evaluator), backend,
                    batch_size=batch_size, progress=False)
    if run.failed:
        o = run.failed[0]
        raise ModelError(f"{gain_name} = {gains[o.index]:g}: {o.error}")
    curves: dict[str, list] = {}
    units: dict[str, str] = {}
    for o in run.outcomes:
        for quantity, (values, unit) in o.record.items():
            curves.setdefault(quantity, []).append(values)
            units[quantity] = unit
    arrays = {q: np.array(v) for q, v in curves.items()}
    study = GainStudy(feedback, structure, gain_name, gains, excitation, speeds, arrays, units)
    chosen = resonance_quantities or [q for q in arrays if q.startswith("bearing")]
    for quantity in chosen:
        if quantity not in arrays:
            raise ModelError(f"no response {quantity!r} to follow resonances of; known: "
                             + ", ".join(arrays))
        c = arrays[quantity]
        for where, amp in _follow(c, speeds, peak_fraction):
            win = np.abs(speeds - where[0]) <= window_rpm
            k0 = int(np.argmin(np.abs(speeds - where[0])))
            study.resonances.append(Resonance(
                quantity, where, amp,
                100 * (1 - c[:, win].max(axis=1) / c[0, win].max()),
                100 * (1 - c[:, k0] / c[0, k0])))
    return study
