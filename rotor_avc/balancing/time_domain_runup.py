"""Time-domain run-up of a LinearPlant machine with the balancer block (rotor_avc.sim stepper).

The plant is :class:`rotor_avc.sim.stepper.PlantStepper` (exact sampled-data plant, linear speed
ramp, the tangential ``Omega'`` term included) carrying the true unbalance; every sample the
block reads the foot accelerations (its signals) with Gaussian noise, the shaft angle, speed and
acceleration and the balancer's actual position, and the stepper takes the balancer's correction
at the middle of the coming interval (``set_correction``, effective from the next step on). The
actuator forces stay zero: the run is of the machine with its feedback loops open (a config with
controllers is refused -- their digital blocks belong to the lockstep loop, not to this run).
Unlike :mod:`.quasi_steady`, this includes the transient vibration of every resonance passage.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..sim.speed_profile import ramp
from ..sim.stepper import PlantStepper
from .machine_rls import MachineSample


@dataclass
class MachineTimeRecord:
    t: np.ndarray
    speed: np.ndarray
    outputs: np.ndarray           # (N, C) the objective channels (time signals)
    channels: tuple[str, ...]
    position: np.ndarray
    estimate: np.ndarray          # (N, 2)
    events: list


def simulate_machine_time(setup, block=None) -> MachineTimeRecord:
    """Run ``setup.runup`` in the time domain; ``block=None``: no balancing."""
    machine, sc, plane = setup.machine, setup.runup, setup.plane
    if machine.controllers:
        raise ModelError("the time-domain balancing run needs a machine without controllers "
                         "(its feedback loops open); use the quasi-steady run for closed loops")
    T = sc.sample_period_s
    profile = ramp(sc.speed0_rad_s, sc.stop_rad_s, sc.duration_s)
    stepper = PlantStepper(machine.plant, T, profile,
                           {"static": sc.unbalance[0], "moment": sc.unbalance[1]})
    layout = stepper.layout
    sig = [layout.index(f"foot_{c}_az") if c in {a.id for a in machine.plant.actuators}
           else layout.index(c) for c in setup.signals.channels]
    obj = [layout.index(c) for c in setup.objective.channels]
    actuator = setup.actuator()
    N = int(np.floor(sc.duration_s / T)) + 1
    rng = np.random.default_rng(sc.seed)
    noise = rng.normal(0.0, sc.noise_std, (N, len(sig)))
    forces = np.zeros(stepper.n_inputs)
    rec = MachineTimeRecord(np.arange(N) * T, np.zeros(N), np.zeros((N, len(obj))),
                            setup.objective.channels, np.zeros(N, complex),
                            np.zeros((N, 2), complex), [])
    y = stepper.reset()
    if block is not None:
        block.reset()
    for k in range(N):
        t = k * T
        speed, accel, angle = (float(v) for v in profile.sample(np.array(t)))
        pos = actuator.position(t)
        rec.speed[k], rec.outputs[k], rec.position[k] = speed, y[obj], pos
        if block is not None:
            out = block.step(MachineSample(t, angle, speed, accel, y[sig] + noise[k], pos))
            if out.new_move:
                actuator.command(out.target, t)
            rec.estimate[k] = (out.estimate["static"], out.estimate["moment"])
            stepper.set_correction(plane.corrections(actuator.position(t + T / 2)))
        y = stepper.step(forces)
    rec.events = list(block.events) if block is not None else []
    return rec
