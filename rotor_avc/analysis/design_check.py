"""Design checks before anything runs a machine's controllers (``simulate``, the nodes,
``controller``): the sampled closed loop stable, every ``G_c`` proper and stable, the sample
rate above the plant's modes.

* **Proper** -- an ideal (improper) PD/PID cannot run as a causal filter (the derivative
  needs its filter pole): always refused.
* **Stable** -- the discrete closed-loop poles of :class:`~rotor_avc.analysis.sampled_loop.SampledLoop`
  (DESIGN.md section 3: plant, sampling, hold, the discretised controllers, their delays) at each
  speed checked, ``max |z| < 1``; a controller ``G_c(s)`` with a pole in the right half-plane
  (it runs away on its own as soon as a limit opens its loop). Negative feedback gains, gains
  beyond the stable range and unstable ``G_c`` all show here. Refused with the poles that cause
  it (frequency ``|Im s| / 2 pi`` and damping ratio ``-Re s / |s|`` of ``s = ln(z) / T``)
  unless the config says ``control.allow_unstable: true`` (then a warning).
* **Resolved** -- at very high sample rates the poles crowd at ``z = 1``: a pole within
  :data:`RESOLUTION` of the unit circle cannot be told stable or unstable from the round-off
  of the eigenvalues (about 1e-9 here), so the verdict is refused with the fix (a lower rate).
* **Sampled fast enough** -- a mode of interest (the first ``analysis.worst_case.n_modes``
  undamped natural frequencies at standstill, the modes the controllers act on) at or above the
  Nyquist frequency ``fs / 2`` gets a warning naming it: the controller cannot act on it and it
  aliases into the band below.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.linalg

from ..control.block import build_digital_controllers
from ..errors import ModelError
from .sampled_loop import SampledLoop

#: ``| |z| - 1 |`` below which a sampled pole's stability is not resolved in double precision
RESOLUTION = 1e-7
#: most speeds a scenario is checked at (its extremes and held speeds, thinned)
MAX_SPEEDS = 6


class DesignError(ModelError):
    """A design the checks refuse (unstable, improper, unresolved); the message names the poles
    or the controller and the fix."""


@dataclass
class DesignCheck:
    """Outcome: ``refusals`` (allowed by ``allow_unstable``), ``fatal`` (never allowed),
    ``warnings``, and the unstable poles found (rows of ``speed_hz``, ``freq_hz``,
    ``damping_ratio``, ``growth_per_s``)."""

    sample_rate_hz: float
    refusals: list[str] = field(default_factory=list)
    fatal: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    unstable_poles: list[dict] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not (self.refusals or self.fatal)

    def enforce(self, allow_unstable: bool, where: str) -> list[str]:
        """Raise :class:`DesignError` (one message, every reason) unless the design passes --
        refusals pass with ``allow_unstable``; returns the warnings to show (with the allowed
        refusals among them)."""
        blocking = self.fatal + ([] if allow_unstable else self.refusals)
        if blocking:
            fix = ("" if self.fatal or not self.refusals else
                   " -- fix the design, or set control.allow_unstable: true for a deliberate "
                   "instability study")
            raise DesignError(f"{where}: " + "; ".join(blocking) + fix)
        allowed = [f"{r} (running anyway: control.allow_unstable is true)" for r in self.refusals]
        return allowed + self.warnings

    def growing_mode(self, rate_per_s: float | None = None) -> str | None:
        """The unstable pole that grows fastest (or closest to ``rate_per_s``), as text."""
        if not self.unstable_poles:
            return None
        key = ((lambda r: -r["growth_per_s"]) if rate_per_s is None
               else (lambda r: abs(r["growth_per_s"] - rate_per_s)))
        return describe_pole(min(self.unstable_poles, key=key))


def describe_pole(row: dict) -> str:
    return (f"{row['freq_hz']:.4g} Hz, damping ratio {row['damping_ratio']:.3g} (grows "
            f"e^({row['growth_per_s']:.3g} t)) at {row['speed_hz']:g} Hz shaft speed")


def natural_frequencies_hz(plant) -> np.ndarray:
    """Undamped natural frequencies at standstill, ascending, rigid-body modes left out (Hz)."""
    w2 = scipy.linalg.eigh(plant.stiffness, plant.mass, eigvals_only=True)
    w = np.sqrt(np.clip(w2, 0.0, None))
    return w[w > 1e-6 * max(w.max(), 1.0)] / (2 * math.pi)


def _controller_checks(machine, out: DesignCheck) -> None:
    for act_id, ctrl in machine.controllers.items():
        if not ctrl.is_proper:
            out.fatal.append(f"controllers.{act_id}: the {ctrl.structure} controller G_c(s) is "
                             "improper (an ideal derivative cannot run as a causal filter) -- add "
                             "derivative_filter_s")
            continue
        poles = np.roots(ctrl.den)                       # none for a constant den
        scale = float(np.max(np.abs(poles), initial=1.0))
        bad = poles[poles.real > 1e-9 * scale]
        if bad.size:
            txt = ", ".join(f"{p.real:+.4g}{p.imag:+.4g}j rad/s" for p in bad)
            out.refusals.append(f"controllers.{act_id}: G_c(s) has a pole in the right "
                                f"half-plane ({txt}): the controller runs away on its own")


def _rate_warning(machine, T: float, out: DesignCheck) -> None:
    f = natural_frequencies_hz(machine.plant)[:machine.analysis.worst_case.n_modes]
    above = np.flatnonzero(f >= 0.5 / T)
    if above.size:
        i = int(above[0])
        more = (f" and {above.size - 1} more up to {f[-1]:.4g} Hz" if above.size > 1 else "")
        out.warnings.append(
            f"the {1 / T:g} Hz sample rate is below twice the plant's mode {i + 1} at "
            f"{f[i]:.4g} Hz{more} (the modes of interest: analysis.worst_case.n_modes): the "
            f"controller cannot act on them and they alias -- raise the rate above "
            f"{2 * f[-1]:.4g} Hz")


def check_design(machine, sample_period_s: float, speeds_rad_s, w_F_of: Callable[[float], float]
                 ) -> DesignCheck:
    """Every check of the module docstring at the given speeds (``w_F_of(speed)``: the damping
    frequency the run or analysis uses)."""
    out = DesignCheck(1.0 / sample_period_s)
    _controller_checks(machine, out)
    _rate_warning(machine, sample_period_s, out)
    if out.fatal or not machine.controllers:
        return out
    loop = SampledLoop.from_blocks(machine.plant,
                                   build_digital_controllers(machine, sample_period_s))
    unresolved = []
    for speed in speeds_rad_s:
        poles = loop.poles(float(speed), float(w_F_of(speed)))
        mag = np.abs(poles.z)
        near = np.abs(mag - 1.0) < RESOLUTION
        if near.any():
            unresolved.append(float(speed))
            continue
        grow = poles.z[mag >= 1.0]
        for zi, si in zip(grow, np.log(grow.astype(complex)) / sample_period_s):
            if zi.imag < 0:
                continue                                  # one of each conjugate pair
            out.unstable_poles.append({
                "speed_hz": float(speed) / (2 * math.pi), "freq_hz": abs(si.imag) / (2 * math.pi),
                "damping_ratio": float(-si.real / abs(si)),     # |s| > 0: |z| >= 1 + RESOLUTION
                "growth_per_s": float(si.real)})
    if unresolved:
        out.fatal.append(f"at {1 / sample_period_s:g} Hz the sampled loop has poles within "
                         f"{RESOLUTION:g} of |z| = 1 (at {unresolved[0] / (2 * math.pi):g} Hz "
                         "shaft speed): its stability is not resolved in double precision -- "
                         "lower the sample rate")
    if out.unstable_poles:
        rows = sorted(out.unstable_poles, key=lambda r: -r["growth_per_s"])
        out.refusals.append(f"the sampled closed loop at {1 / sample_period_s:g} Hz is UNSTABLE: "
                            f"{len(rows)} pole(s) with |z| >= 1, e.g. "
                            + "; ".join(describe_pole(r) for r in rows[:3]))
    return out


def scenario_speeds(profile) -> np.ndarray:
    """The speeds a run is checked at: extremes and held speeds (at most :data:`MAX_SPEEDS`)."""
    speeds = np.unique(np.concatenate([[profile.min_speed_rad_s, profile.max_speed_rad_s],
                                       profile.held_speeds()]))
    if speeds.size > MAX_SPEEDS:
        speeds = speeds[np.unique(np.linspace(0, speeds.size - 1, MAX_SPEEDS).round().astype(int))]
    return speeds


def check_scenario(scenario) -> DesignCheck:
    """:func:`check_design` of a scenario's run: its rate, speeds and damping rule."""
    plant = scenario.machine.plant
    return check_design(scenario.machine, scenario.sample_period_s,
                        scenario_speeds(scenario.profile),
                        lambda w: float(scenario.damping.w_F(plant, w)))


def enforce_scenario(scenario, where: str) -> list[str]:
    """:func:`check_scenario`, refused unless ``control.allow_unstable``; the warnings."""
    return check_scenario(scenario).enforce(scenario.machine.control.allow_unstable, where)


#: a run of a design found unstable diverged when its envelope grew by this factor
DIVERGENCE_GROWTH = 1e3


class DivergenceError(ModelError):
    """A simulated run grew without bound (an unstable loop run with ``allow_unstable``)."""


class DivergenceWatch:
    """Whether a run diverged, fed its time-series blocks in order (memory independent of the
    run's length): a value that is not finite (overflow, said at once by :meth:`feed`), or --
    for a design ``check`` found unstable -- a controller ``blocks`` that had to reject
    measurements (the loop ran beyond the plausible range) or a channel whose largest value
    over the last tenth of the ``n_steps`` samples is :data:`DIVERGENCE_GROWTH` times that over
    the first tenth (the growth rate measured between the two names the growing mode)."""

    def __init__(self, check: DesignCheck, n_steps: int, blocks=None):
        self.check, self.blocks = check, blocks or {}
        self.tenth = n_steps // 10
        self.n_steps = n_steps
        self.seen = 0
        self.first: dict[str, float] = {}
        self.last: dict[str, float] = {}
        self.units: dict[str, str] = {}
        self.span_s = [None, None]           # mid-times of the first and the last tenth

    def feed(self, ts) -> str | None:
        """Take the next block; why the run overflowed in it, or None."""
        t, k0 = ts.time_s, self.seen
        self.seen += len(t)
        self.units = ts.units
        for name, v in ts.channels.items():
            bad = np.flatnonzero(~np.isfinite(v))
            if bad.size:
                mode = self.check.growing_mode()
                return (f"the run overflowed: {name} is {v[bad[0]]} at t = {t[bad[0]]:.4g} s"
                        + (f" (the unstable closed-loop pole {mode})" if mode else ""))
        k = np.arange(k0, self.seen)
        head, tail = k < self.tenth, k >= self.n_steps - self.tenth
        for which, mask, store in ((0, head, self.first), (1, tail, self.last)):
            if mask.any():
                for name, v in ts.channels.items():
                    store[name] = max(store.get(name, 0.0), float(np.max(np.abs(v[mask]))))
                mid = self.tenth // 2 if which == 0 else self.n_steps - self.tenth // 2 - 1
                if k0 <= mid < self.seen:
                    self.span_s[which] = float(t[mid - k0])
        return None

    def verdict(self) -> str | None:
        """After the last block: why the run diverged, or None."""
        check = self.check
        if not check.unstable_poles:
            return None
        for act_id, block in self.blocks.items():
            if any(block.faults.values()):
                return (f"the run diverged: controller {act_id} saw its signal beyond "
                        f"+-{block.measurement_limit:g} (measurement_limit) and answered its safe "
                        f"output from there ({block.faults}), as the unstable closed-loop pole "
                        f"{check.growing_mode()}")
        worst = None
        for name, first in self.first.items():
            last = self.last.get(name, 0.0)
            growth = last / first if first > 0 else (np.inf if last > 0 else 1.0)
            if growth >= DIVERGENCE_GROWTH and (worst is None or growth > worst[1]):
                worst = (name, growth, first, last)
        if worst is None:
            return None
        name, growth, first, last = worst
        span_s = (self.span_s[1] - self.span_s[0]) if None not in self.span_s else 0.0
        rate = math.log(growth) / span_s if np.isfinite(growth) and span_s > 0 else None
        unit = self.units.get(name, "")
        return (f"the run diverged: {name} grew from {first:.3g} to {last:.3g} {unit} "
                + (f"(e^({rate:.3g} t)) " if rate else "")
                + f"as the unstable closed-loop pole {check.growing_mode(rate)}")


def fault_summary(blocks) -> list[str]:
    """One line per controller block that rejected measurements or reset its filter."""
    return [f"controller {act_id} rejected measurements beyond +-{b.measurement_limit:g} or reset "
            f"its filter ({', '.join(f'{k} {v}' for k, v in b.faults.items() if v)}; safe output "
            f"{b.safe_output})" for act_id, b in blocks.items() if any(b.faults.values())]
