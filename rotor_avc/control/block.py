"""The digital foot controller block: what the simulator, the in-process loop and the ROS node run.

At sample ``k`` (DESIGN.md section 3) the block takes the foot's measured signal (its
``feedback`` kind: displacement, velocity or acceleration) and returns the actuator force held
over ``[t_k, t_k+1)``::

    f_k = -lim( G_d(z) * signal_{k - d} )        (Werner 2021 eq. 7: f_a = -G_c(s) s^k z_a)

with ``G_d`` the discretised ``G_c`` (:mod:`rotor_avc.control.discretize`), ``d`` extra
``delay_samples``, and ``lim`` the force and rate limits with anti-windup
(:mod:`rotor_avc.control.limits`). Everything per sample is plain Python floats.

Faults never reach the filter (the state stays finite and nothing latches):

* a measurement outside ``|signal| <= measurement_limit`` (a physical range in the signal's SI
  unit; from a config, default :data:`PLAUSIBLE_LIMITS` of the feedback kind), or not finite
  (the limit of a block built without one), is rejected: the
  filter is not stepped, the block answers its safe output (``hold``: the last force, or
  ``zero``) and counts it in :attr:`DigitalController.faults`; the next plausible measurement
  steps the filter as if the rejected one had not come (recovery in one sample);
* an output that is not finite (only an unstable ``G_c`` run with ``allow_unstable`` gets there)
  resets the filter to rest and answers the safe output (counted as ``filter_reset``);
* with a force or rate limit, anti-windup defaults to ``back_calculation`` (a saturated
  integrator would otherwise hold the limit for as long as the excess it built up: after one
  large spike, for good). With it the stored state stays at the limit, so a controller whose
  integrator forgets (``leak_hz``, or a PI on displacement) is back on its normal output within
  a few of its time constants (tested); a pure integrator on a derivative signal keeps the force
  it reached (the held-force drift mode of :mod:`rotor_avc.analysis.sampled_loop`) -- give it
  a leak where spikes inside the plausible range are expected.

:func:`build_digital_controllers` builds one block per controlled actuator of a
:class:`rotor_avc.machine.Machine` from its config::

    control:                      # machine-wide (all optional; rotor_avc.settings.ControlSettings)
      sample_rate_hz: 5000.0
      method: tustin              # tustin | zoh | foh
      prewarp_hz: 100.0           # tustin only, below Nyquist
    controllers:                  # per actuator (rotor_avc.control.spec.ControllerSettings)
      DL: {type: I, feedback: acceleration, ki: 1.4e+5,
           force_limit_n: 2000.0, rate_limit_n_per_s: 1.0e+6,
           anti_windup: back_calculation, back_calculation_gain: 50.0, delay_samples: 0,
           measurement_limit: 1.0e+4}       # m/s^2 here; beyond it a measurement is rejected
"""
from __future__ import annotations

import math
import sys
from collections import deque

from ..errors import ConfigError, ModelError
from .discretize import DiscreteTf, check_period, discretize_controller
from .filter import IirFilter
from .limits import OutputLimits, check_anti_windup, limited_step
from .spec import FEEDBACK_UNITS as UNITS, PLAUSIBLE_LIMITS, ControllerSettings
SAFE_OUTPUTS = ("hold", "zero")
#: the fault counters of a block (:attr:`DigitalController.faults`)
FAULT_KINDS = ("implausible", "filter_reset")


class DigitalController:
    """One foot's discrete controller: filter, delay, limits, anti-windup (module docstring)."""

    def __init__(self, tf: DiscreteTf, *, force_limit_n: float | None = None,
                 rate_limit_n_per_s: float | None = None, anti_windup: str = "none",
                 back_calculation_gain: float | None = None, delay_samples: int = 0,
                 measurement_limit: float | None = None, safe_output: str = "hold",
                 name: str = ""):
        if isinstance(delay_samples, bool) or not isinstance(delay_samples, int) or delay_samples < 0:
            raise ModelError(f"delay_samples must be an integer >= 0 (got {delay_samples!r})")
        self.name = name
        self.tf = tf
        self.sample_period_s = tf.sample_period_s
        self.feedback = tf.feedback
        self.delay_samples = delay_samples
        self.filter = IirFilter(tf.b, tf.a)
        self.limits = OutputLimits(tf.sample_period_s, force_limit_n, rate_limit_n_per_s)
        self.anti_windup = anti_windup
        self._kb = check_anti_windup(anti_windup, self.limits, tf.sample_period_s,
                                     back_calculation_gain)
        self._limited = self.limits.active
        self._delay: deque[float] = deque([0.0] * delay_samples)
        self.last_force_n = 0.0
        limit = sys.float_info.max if measurement_limit is None else measurement_limit
        if not (math.isfinite(limit) and limit > 0):
            raise ModelError(f"measurement_limit must be finite and > 0 (got {limit})")
        self.measurement_limit = float(limit)
        self.safe_output = safe_output
        self.faults = dict.fromkeys(FAULT_KINDS, 0)
        #: samples answered at the force limit (a pure integrator can hold there: leak_hz)
        self.saturated_samples = 0

    @classmethod
    def from_settings(cls, tf: DiscreteTf, entry: ControllerSettings,
                      name: str = "") -> "DigitalController":
        """The block of a ``controllers:`` entry around its discretised ``G_c``: anti-windup
        ``back_calculation`` when a limit is given (else ``none``) and the plausible range of the
        feedback kind (:data:`PLAUSIBLE_LIMITS`) unless the entry says otherwise."""
        limited = entry.force_limit_n is not None or entry.rate_limit_n_per_s is not None
        default_anti_windup = "back_calculation" if limited else "none"
        return cls(tf, force_limit_n=entry.force_limit_n,
                   rate_limit_n_per_s=entry.rate_limit_n_per_s,
                   anti_windup=entry.anti_windup or default_anti_windup,
                   back_calculation_gain=entry.back_calculation_gain,
                   delay_samples=entry.delay_samples,
                   measurement_limit=(PLAUSIBLE_LIMITS[tf.feedback]
                                      if entry.measurement_limit is None
                                      else entry.measurement_limit),
                   name=name)

    @property
    def safe_output(self) -> str:
        return self._safe

    @safe_output.setter
    def safe_output(self, policy: str) -> None:
        if policy not in SAFE_OUTPUTS:
            raise ModelError(f"unknown safe_output {policy!r}; use one of " + ", ".join(SAFE_OUTPUTS))
        self._safe = policy

    def safe_force_n(self) -> float:
        """The force answered for a rejected measurement (policy :attr:`safe_output`)."""
        return self.last_force_n if self._safe == "hold" else 0.0

    # -- state -------------------------------------------------------------------------------
    def reset(self) -> None:
        """At rest: zero filter state, empty (zero) delay line, zero force."""
        self.filter.reset()
        self.limits.reset(0.0)
        self._delay = deque([0.0] * self.delay_samples)
        self.last_force_n = 0.0

    @property
    def state(self) -> dict:
        """Filter state, pending delayed inputs (oldest first), last force, gain factor."""
        return {"filter": self.filter.state, "delay": tuple(self._delay),
                "last_force_n": self.last_force_n, "gain": self.filter.gain}

    def set_state(self, state: dict) -> None:
        """Restore a :attr:`state` (filter state, delay line oldest first, last force; without
        ``last_force_n``, a filter state set by hand, the last force is 0 N as after
        :meth:`reset`)."""
        delay = [float(v) for v in state.get("delay", ())]
        if len(delay) != self.delay_samples or not all(math.isfinite(v) for v in delay):
            raise ModelError(f"delay state must be {self.delay_samples} finite numbers (got {delay})")
        self.filter.set_state(state["filter"])
        self._delay = deque(delay)
        self.last_force_n = float(state.get("last_force_n", 0.0))
        self.limits.reset(-self.last_force_n)
        if "gain" in state:
            self.filter.set_gain(state["gain"])

    @property
    def gain(self) -> float:
        """Gain factor relative to the designed ``G_c`` (1 = as configured)."""
        return self.filter.gain

    def set_gain(self, factor: float) -> None:
        """Scale ``G_c`` by ``factor`` without a bump in the stored force (see filter module)."""
        self.filter.set_gain(factor)

    def init_steady_state(self, measurement: float = 0.0, force_n: float | None = None) -> None:
        """Start in the steady state of a constant ``measurement`` (force ``-G_d(1) signal``, or
        the held ``force_n`` of an integrating controller with zero input): no transient."""
        if not math.isfinite(measurement):
            raise ModelError(f"measurement must be finite (got {measurement})")
        before = self.filter.state
        self.filter.init_steady_state(measurement, None if force_n is None else -force_n)
        y = self.filter.output(measurement)
        if abs(y) > self.limits.force_limit_n * (1 + 1e-12):
            self.filter.set_state(before)
            raise ModelError(f"steady-state force {-y:g} N exceeds force_limit_n "
                             f"{self.limits.force_limit_n:g} N")
        self.limits.reset(y)
        self._delay = deque([float(measurement)] * self.delay_samples)
        self.last_force_n = -y

    # -- stepping ----------------------------------------------------------------------------
    def step(self, measurement: float) -> float:
        """Measured signal at ``t_k`` -> actuator force (N) to hold over ``[t_k, t_k+1)``."""
        measurement = float(measurement)          # numpy scalars would slow every later step
        limit = self.measurement_limit
        if not -limit <= measurement <= limit:   # also false for NaN
            self.faults["implausible"] += 1
            return self.safe_force_n()
        if self.delay_samples:
            self._delay.append(measurement)
            measurement = self._delay.popleft()
        if self._limited:
            y = limited_step(self.filter, measurement, self.limits, self.anti_windup, self._kb)
            if not -self.limits.force_limit_n < y < self.limits.force_limit_n:
                self.saturated_samples += 1
        else:
            y = self.filter.step(measurement)
        if y - y != 0.0:                          # inf or NaN: an unstable G_c ran away
            self.faults["filter_reset"] += 1
            force = self.safe_force_n()
            self.reset()
            self.last_force_n = force
            self.limits.reset(-force)
            return force
        self.last_force_n = -y
        return -y

    def describe(self) -> str:
        extras = []
        if self.limits.force_limit_n < math.inf:
            extras.append(f"force limit {self.limits.force_limit_n:g} N")
        if self.limits.max_step_n < math.inf:
            extras.append(f"rate limit {self.limits.max_step_n / self.sample_period_s:g} N/s")
        if self.anti_windup != "none":
            extras.append(f"anti-windup {self.anti_windup}")
        if self.delay_samples:
            extras.append(f"{self.delay_samples} extra delay samples")
        if self.measurement_limit < sys.float_info.max:
            extras.append(f"measurements beyond +-{self.measurement_limit:g} "
                          f"{UNITS[self.feedback]} rejected ({self._safe})")
        head = f"{self.name}: " if self.name else ""
        return head + self.tf.describe() + ("\n  " + ", ".join(extras) if extras else "")


# -- from a machine config ---------------------------------------------------------------------
def sampling(machine, sample_period_s: float | None = None):
    """``(T, method, prewarp_hz)`` from the machine's ``control:`` settings (``T`` overridable)."""
    ctl = machine.control
    T = check_period(1.0 / machine.sample_rate_hz if sample_period_s is None
                     else sample_period_s)
    prewarp = ctl.prewarp_hz
    if prewarp is not None and prewarp >= 0.5 / T:
        raise machine.config.section("control").error(
            "prewarp_hz", f"{prewarp:g} Hz is at or above the Nyquist frequency "
            f"{0.5 / T:g} Hz of the {1 / T:g} Hz sample rate",
            fix="lower prewarp_hz or raise sample_rate_hz")
    return T, ctl.method, prewarp


def build_digital_controllers(machine, sample_period_s: float | None = None
                              ) -> dict[str, DigitalController]:
    """One :class:`DigitalController` per controlled actuator of ``machine`` (config order), set
    up by the actuator's ``controllers:`` entry (:meth:`DigitalController.from_settings`; a
    controller given in code without an entry gets the defaults)."""
    T, method, prewarp = sampling(machine, sample_period_s)
    feet = machine.config.section("controllers", {})
    entries = machine.controller_settings
    blocks = {}
    for act_id, ctrl in machine.controllers.items():
        sec = feet.section(act_id, {})
        try:
            tf = discretize_controller(ctrl, T, method, prewarp)
        except ModelError as exc:
            raise ConfigError(sec.path, str(exc), source=sec.source) from None
        try:
            blocks[act_id] = DigitalController.from_settings(
                tf, entries.get(act_id, ControllerSettings()), name=act_id)
        except ModelError as exc:
            key = "back_calculation_gain" if "back_calculation_gain" in str(exc) else "anti_windup"
            raise sec.error(key, str(exc)) from None
    return blocks
