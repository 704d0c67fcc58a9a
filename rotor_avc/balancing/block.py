"""The balancer block: imbalance estimator + balancing law + the paper's supervisor.

One block with explicit state (``reset()``, ``step(sample) -> BalancerOutput``) that both the
in-process loops and the balancer node run, once per sample (DESIGN.md section 3). The supervisor
is the paper's four-step procedure (Zhou & Shi 2001 section 3, Figure 4(g)):

1. ``estimate``: hold the balancer at its initial position and run the estimator until
   ``estimate_until_s``;
2. then follow the law: at every change of its mode, command the target the law computes from the
   *current* estimate (the paper moves once per mode); a law marked ``continuous`` (the Werner 2021
   least-squares law, whose optimum moves with the speed) is re-targeted every sample;
3. keep the estimator running throughout (the balancer's known forcing is in the regression).

The actuator (:mod:`.actuator`) limits the rate of the commanded moves; the block only says where
to go. Estimators provide ``reset()``, ``update(sample) -> bool``, ``amplitudes()`` and ``std()``;
laws provide ``decide(t, speed, amplitudes) -> (mode, target or None to hold)``,
``corrections(position)`` and ``continuous``. Every amplitude is a LinearPlant excitation
amplitude (``{"static": ..., "moment": ...}``) of the machine's model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..blocks import SnapshotState
from ..errors import ModelError


@dataclass(frozen=True)
class BalancerOutput:
    """What the block publishes at one sample."""

    t: float
    mode: str
    target: complex                       # balancer position target (balancer coordinates)
    corrections: dict[str, complex]       # excitation amplitudes the target adds
    new_move: bool                        # a new target was commanded at this sample
    estimate: dict[str, complex]          # estimated imbalance amplitudes
    std: dict[str, float] = field(default_factory=dict)   # their standard deviations
    held: bool = False                    # the estimator held this sample


class BalancerBlock(SnapshotState):
    """Estimator + law + supervisor; see the module docstring. A :class:`rotor_avc.blocks.
    Estimator` block (state: the estimator's, the mode, target and commanded moves)."""

    STATE = ("estimator", "mode", "target", "events")

    def __init__(self, estimator, law, estimate_until_s: float = 0.0,
                 initial_position: complex = 0j):
        if not (math.isfinite(estimate_until_s) and estimate_until_s >= 0):
            raise ModelError(f"estimate_until_s must be >= 0 (got {estimate_until_s})")
        self.estimator = estimator
        self.law = law
        self.estimate_until_s = float(estimate_until_s)
        self.initial_position = complex(initial_position)
        self.reset()

    def reset(self) -> None:
        self.estimator.reset()
        self.mode = "estimate"
        self.target = self.initial_position
        #: (time, mode, target) of every commanded move
        self.events: list[tuple[float, str, complex]] = []

    def step(self, sample) -> BalancerOutput:
        used = self.estimator.update(sample)
        est = self.estimator.amplitudes()
        t = sample.t
        new_move = False
        if t >= self.estimate_until_s:
            mode, target = self.law.decide(t, sample.speed, est)
            if target is None:                 # the law holds: keep the current target
                target = self.target
            if mode != self.mode or (self.law.continuous and target != self.target):
                new_move = target != self.target
                self.mode, self.target = mode, complex(target)
                if new_move:
                    self.events.append((t, mode, self.target))
        return BalancerOutput(t, self.mode, self.target, self.law.corrections(self.target),
                              new_move, est, self.estimator.std(), not used)
