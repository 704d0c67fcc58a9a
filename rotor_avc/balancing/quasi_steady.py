"""Quasi-steady run-up of a LinearPlant machine with the balancer block in the loop.

The frequency-domain stand-in for a time-domain run-up: at each sample the machine is taken to be
in its 1x steady state at the current speed (influence coefficients of :mod:`.influence`, with the
tangential ``Omega'`` term), so that

* the balancer's signals are ``Re{A_sig (u + h_p c(t)) e^{j theta}}`` plus Gaussian noise of the
  stated standard deviation, ``c(t)`` being the actuator's actual (rate-limited) position;
* the objective channels' amplitudes are ``|A_obj (u + h_p c(t))|`` (with balancing) and
  ``|A_obj u|`` (without).

It exercises estimator, law, supervisor and actuator together on the machine model; what it
leaves out is the transient of a resonance passage (the "sudden" free vibration of Zhou & Shi 2001
App. A), which a slow run-up keeps small and the time-domain simulator (rotor_avc.sim) includes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

from ..errors import ModelError
from .actuator import BalancerActuator
from .influence import InfluenceTable
from .machine_rls import MachineSample
from .machine_runup import MachineRunup
from .plane import MachinePlane


@dataclass
class MachineRunupRecord:
    t: np.ndarray
    speed: np.ndarray
    position: np.ndarray          # actual correction [kg m]
    target: np.ndarray
    mode: np.ndarray
    estimate: np.ndarray          # (N, 2): estimated (u_e, u_alpha)
    std: np.ndarray               # (N, 2)
    response: np.ndarray          # (N, C) objective amplitudes with balancing
    response_none: np.ndarray     # (N, C) without balancing
    channels: tuple[str, ...]
    events: list


def simulate_machine_runup(sc: MachineRunup, signals: InfluenceTable, objective: InfluenceTable,
                           plane: MachinePlane, block, actuator: BalancerActuator
                           ) -> MachineRunupRecord:
    """Run the block through the run-up (see the module docstring)."""
    N = int(math.floor(sc.duration_s / sc.sample_period_s)) + 1
    t = np.arange(N) * sc.sample_period_s
    speed = sc.speed0_rad_s + sc.accel_rad_s2 * t
    angle = sc.speed0_rad_s * t + 0.5 * sc.accel_rad_s2 * t**2
    if not (signals.covers(speed[-1]) and objective.covers(speed[-1])):
        raise ModelError("the influence tables do not reach the run-up's end speed")
    u = np.asarray(sc.unbalance, complex)
    noise = np.random.default_rng(sc.seed).normal(0.0, sc.noise_std, (N, len(signals.channels)))
    block.reset()
    actuator.reset()
    C = len(objective.channels)
    rec = MachineRunupRecord(t, speed, np.zeros(N, complex), np.zeros(N, complex),
                             np.empty(N, dtype=object), np.zeros((N, 2), complex),
                             np.zeros((N, 2)), np.zeros((N, C), complex),
                             np.zeros((N, C), complex), objective.channels, [])
    for k in range(N):
        pos = actuator.position(t[k])
        amps = u + pos * plane.influence
        w = speed[k]
        if signals.covers(w):
            y = (signals.at(w, sc.accel_rad_s2) @ amps * np.exp(1j * angle[k])).real
        else:
            y = np.zeros(len(signals.channels))
        out = block.step(MachineSample(t[k], angle[k], w, sc.accel_rad_s2, y + noise[k], pos))
        if out.new_move:
            actuator.command(out.target, t[k])
        if objective.covers(w):
            G = objective.at(w, sc.accel_rad_s2)
            rec.response[k] = G @ amps
            rec.response_none[k] = G @ u
        rec.position[k], rec.target[k], rec.mode[k] = pos, actuator.target, out.mode
        rec.estimate[k] = (out.estimate["static"], out.estimate["moment"])
        rec.std[k] = (out.std["static"], out.std["moment"])
    rec.events = list(block.events)
    return rec


def resonance_comparison(speed: np.ndarray, none: np.ndarray, others: dict[str, np.ndarray],
                         prominence_db: float = 3.0, resonances_rad_s=None) -> list[dict]:
    """Per resonance of the unbalanced envelope ``none`` (peaks standing out by
    ``prominence_db``, or the given ``resonances_rad_s``): its speed and, in the window between
    neighbouring resonances, the peak of ``none`` and of each other envelope with the reduction
    in dB."""
    if resonances_rad_s is None:
        with np.errstate(divide="ignore"):
            db = 20 * np.log10(np.maximum(none, 1e-300))
        peaks, _ = find_peaks(db, prominence=prominence_db)
    else:
        peaks = np.searchsorted(speed, np.asarray(resonances_rad_s, dtype=float))
    edges = [0] + [int((a + b) // 2) for a, b in zip(peaks[:-1], peaks[1:])] + [len(speed)]
    rows = []
    for i, p in enumerate(peaks):
        sl = slice(edges[i], edges[i + 1])
        row = {"speed_hz": float(speed[p] / (2 * np.pi)), "none": float(none[sl].max())}
        for name, env in others.items():
            peak = float(env[sl].max())
            row[name] = peak
            row[f"{name}_reduction_db"] = float(20 * np.log10(row["none"] / peak)) if peak > 0 \
                else math.inf
        rows.append(row)
    return rows
