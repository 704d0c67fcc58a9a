"""The one-plane machine balancer as a block of the lockstep loop (rotor_avc.sim.loop).

What the balancer node runs, and what the in-process loop runs in its place: at every plant
sample it receives the sample time, shaft angle and speed and the plant's measurement vector
(:class:`rotor_avc.blocks.LoopSample`) and returns the correction the balancer applies, as
excitation amplitudes ``{"static": c, "moment": j a c}`` of its plane (rotor_avc.balancing.plane).

* Its signals (foot accelerations or plant outputs, ``balancer.signals``) are picked from the
  measurement vector by name.
* The balancer block (estimator + law + supervisor, rotor_avc.balancing.block) runs every
  ``round(balancer.sample_period_s / T)`` plant samples; the correction follows the rate-limited
  actuator (rotor_avc.balancing.actuator) at the middle of the coming interval, as the
  time-domain run-up does (rotor_avc.balancing.time_domain_runup).
* The angular acceleration is the backward difference of the measured speed (what a balancer
  with a speed encoder has), so the node and the in-process loop compute the same numbers.
"""
from __future__ import annotations

import math

import numpy as np

from ..blocks import LoopSample, SnapshotState
from ..errors import ModelError
from .machine_rls import MachineSample


class LoopBalancer(SnapshotState):
    """``reset()``, ``step(sample) -> {excitation: amplitude}`` (see the module docstring); a
    :class:`rotor_avc.blocks.Balancer` block (state: the inner block, the actuator's move, the
    sample count, the last speed, output and correction)."""

    STATE = ("block", "actuator", "_prev_speed", "_k", "last_output", "correction")

    def __init__(self, setup, plant_period_s: float):
        ratio = setup.runup.sample_period_s / plant_period_s
        every = int(round(ratio))
        if every < 1 or abs(ratio - every) > 1e-9 * max(ratio, 1.0):
            raise ModelError(f"balancer.sample_period_s = {setup.runup.sample_period_s:g} s must "
                             f"be a whole multiple of the plant's sample period {plant_period_s:g} s")
        self.setup = setup
        self.T = plant_period_s
        self.every = every
        self.block = setup.block()
        self.actuator = setup.actuator()
        self.plane = setup.plane
        self._channels = list(setup.signals.channels)
        self._index: list[int] | None = None
        self.reset()

    def reset(self) -> None:
        self.block.reset()
        self.actuator.reset()
        self._prev_speed: float | None = None
        self._k = 0
        self.last_output = None
        self.correction = self.plane.corrections(self.actuator.position(0.0))

    def _signal_index(self, names) -> list[int]:
        ids = {a.id for a in self.setup.machine.plant.actuators}
        wanted = [f"foot_{c}_az" if c in ids else c for c in self._channels]
        lookup = {n: i for i, n in enumerate(names)}
        missing = [w for w in wanted if w not in lookup]
        if missing:
            raise ModelError(f"balancer signals {missing} are not among the plant's measurements")
        return [lookup[w] for w in wanted]

    def step(self, sample: LoopSample) -> dict[str, complex]:
        if self._index is None:
            self._index = self._signal_index(sample.names)
        t, speed = sample.t, sample.speed
        accel = 0.0 if self._prev_speed is None else (speed - self._prev_speed) / self.T
        self._prev_speed = speed
        if self._k % self.every == 0:
            signals = np.asarray(sample.signals)[self._index]
            out = self.block.step(MachineSample(t, sample.angle, speed, accel, signals,
                                                self.actuator.position(t)))
            if out.new_move and math.isfinite(abs(out.target)):
                self.actuator.command(out.target, t)
            self.last_output = out
        self._k += 1
        self.correction = self.plane.corrections(self.actuator.position(t + self.T / 2))
        return self.correction

    def estimate(self) -> dict[str, complex]:
        """The current estimate of the unbalance amplitudes (zero before the first update)."""
        if self.last_output is None:
            return {"static": 0j, "moment": 0j}
        return dict(self.last_output.estimate)
