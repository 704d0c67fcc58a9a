"""The block contract of the sampled loop (DESIGN.md section 3): what every block implements.

Plant, controllers, feed-forward (and harmonic) generators and balancers are blocks with explicit
state, stepped once per sample ``k`` at the period ``T``: ``reset()`` (back to the initial
state), ``step(...)`` with one return type each, ``state`` (a snapshot, inspectable) and
``set_state(state)`` (resume from a snapshot: the same steps then give the same outputs). The
in-process loop (:mod:`rotor_avc.sim.loop`) and the ROS nodes call blocks only through these
protocols.

===================  =========================================  ==================================
protocol             ``step`` signature                          implemented by
===================  =========================================  ==================================
:class:`Plant`       ``step(forces_n) -> y_{k+1}`` (array)       ``sim.stepper.PlantStepper``
:class:`Controller`  ``step(signal) -> force_n`` (float)         ``control.block.DigitalController``
:class:`Synchronous` ``step(angle_rad, speed_rad_s) -> forces``  ``control.synchronous.
                     (array, actuator order)                     SynchronousForceGenerator``
:class:`Harmonic`    ``step(signals, angle_rad, speed_rad_s)     ``harmonic.block.
                     -> forces`` (list, actuator order)          HarmonicController``
:class:`Balancer`    ``step(LoopSample) -> {excitation:          ``balancing.loop_block.
                     amplitude}`` or None (keep the last one)    LoopBalancer``
:class:`Estimator`   ``step(sample) -> BalancerOutput``          ``balancing.block.BalancerBlock``
===================  =========================================  ==================================
"""
from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any, Mapping, Protocol, runtime_checkable

import numpy as np

from .errors import ModelError


@dataclass(frozen=True)
class LoopSample:
    """What a balancer sees at sample ``k``: time ``t`` (s), shaft ``angle`` (rad), ``speed``
    (rad/s), ``accel`` (rad/s^2) and the measurement vector ``signals`` (names in ``names``)."""

    k: int
    t: float
    angle: float
    speed: float
    accel: float
    signals: np.ndarray
    names: tuple[str, ...]


@runtime_checkable
class Block(Protocol):
    """``reset()``, ``state`` and ``set_state(state)``; each kind adds its ``step``."""

    def reset(self) -> Any: ...

    @property
    def state(self) -> Any: ...

    def set_state(self, state) -> None: ...


@runtime_checkable
class Plant(Block, Protocol):
    """Holds ``u_k`` over ``[t_k, t_k+1)`` and returns the measurement vector ``y_{k+1}``;
    ``reset()`` returns ``y_0``; ``state`` is ``x_k``."""

    def step(self, forces_n: np.ndarray) -> np.ndarray: ...


@runtime_checkable
class Controller(Block, Protocol):
    """One actuator's feedback: its ``feedback`` signal kind in, its force ``u_k`` [N] out."""

    feedback: str
    sample_period_s: float

    def step(self, signal: float) -> float: ...


@runtime_checkable
class Synchronous(Block, Protocol):
    """Forces locked to the shaft angle (feed-forward) for ``actuator_ids``."""

    actuator_ids: tuple[str, ...]

    def step(self, shaft_angle_rad: float, speed_rad_s: float) -> np.ndarray: ...


@runtime_checkable
class Harmonic(Block, Protocol):
    """Adaptive harmonic control: forces locked to the shaft angle for ``actuator_ids`` whose
    phasors adapt to the ``sensors``' signals (plain floats per sample, numpy per update)."""

    actuator_ids: tuple[str, ...]
    sensors: tuple[str, ...]
    sample_period_s: float

    def step(self, signals, shaft_angle_rad: float, speed_rad_s: float) -> list[float]: ...


@runtime_checkable
class Balancer(Block, Protocol):
    """The correction amplitudes per excitation name, replacing the previous ones, or None to
    keep them; the plant applies them from the next step on."""

    def step(self, sample: LoopSample) -> Mapping[str, complex] | None: ...


@runtime_checkable
class Estimator(Block, Protocol):
    """Imbalance estimate + balancing law + supervisor: one ``BalancerOutput`` per sample."""

    def step(self, sample) -> Any: ...


class SnapshotState:
    """``state`` / ``set_state`` of a block whose state is the attributes named in ``STATE``
    (including its stateful parts): a deep copy of them, restored by a deep copy."""

    STATE: tuple[str, ...] = ()

    @property
    def state(self) -> dict:
        return copy.deepcopy({name: getattr(self, name) for name in self.STATE})

    def set_state(self, state: Mapping) -> None:
        missing = [name for name in self.STATE if name not in state]
        if missing:
            raise ModelError(f"{type(self).__name__} state lacks {', '.join(missing)}")
        for name in self.STATE:
            setattr(self, name, copy.deepcopy(state[name]))
