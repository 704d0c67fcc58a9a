"""The in-process lockstep loop: plant + per-foot controllers (+ balancer), DESIGN.md section 3.

At sample ``k``: the plant's measurement ``y_k`` (from ``x_k`` and ``u_{k-1}``) goes to every
controller, which answers with ``u_k`` (:func:`controller_forces`); the balancer, when present,
sees the same sample and may set a new correction (:func:`balancer_update`); the plant holds
``u_k`` over ``[t_k, t_k+1)`` and advances. This is the reference the ROS graph reproduces:
the plant node calls the same :class:`~rotor_avc.sim.stepper.PlantStepper`, each foot node the
same controller block, and :func:`forces_from_answers` puts their answers in plant order.

The blocks follow the protocols of :mod:`rotor_avc.blocks`: controllers
(:class:`~rotor_avc.blocks.Controller`: ``feedback``, ``step(signal) -> force_n``), the balancer
(:class:`~rotor_avc.blocks.Balancer`: ``step(sample: LoopSample)`` -> the correction amplitude
per excitation name, ``{"static": u_e, "moment": u_alpha}``, replacing the previous one, or None
to keep it; the stepper applies it from the next step on), the feed-forward generator
(:class:`~rotor_avc.blocks.Synchronous`) and the adaptive harmonic controller
(:class:`~rotor_avc.blocks.Harmonic`: its sensor signals, the shaft angle and speed -> forces
added to the feedback forces).

While every controller runs linearly at one speed node, :class:`~rotor_avc.sim.fused.FusedLoop`
does the samples in one matrix product each (the same numbers to rounding; anything else --
limits acting, rejected measurements, other blocks -- goes through the per-sample path below).
"""
from __future__ import annotations

import sys
from operator import itemgetter
import time
from typing import Iterator, Mapping

import numpy as np

from .. import __version__
from ..bag.array_labels import balancer_labels
from ..blocks import Balancer, Harmonic, LoopSample, Synchronous
from ..errors import ModelError
from ..resources import FLOAT_BYTES, check_memory
from ..settings import INITIAL_STATES
from .fused import FusedLoop, fusable
from .steady_state import start_in_steady_state
from .stepper import PlantStepper
from .timeseries import TimeSeries



# -- per-step logic (shared with the ROS nodes) ---------------------------------------------------
def control_plan(stepper: PlantStepper, controllers: Mapping) -> list[tuple[int, object, int]]:
    """``(position in the force vector, controller, index of its signal in y)`` per controller."""
    ids = [a.id for a in stepper.plant.actuators]
    plan = []
    for act_id, ctrl in controllers.items():
        if act_id not in ids:
            raise ModelError(f"controller for {act_id!r}, but the plant's actuators are "
                             + (", ".join(ids) or "none"))
        if abs(ctrl.sample_period_s - stepper.T) > 1e-12 * stepper.T:
            raise ModelError(f"controller {act_id} runs at {1 / ctrl.sample_period_s:g} Hz but "
                             f"the plant is sampled at {1 / stepper.T:g} Hz; lockstep needs one "
                             "rate")
        plan.append((ids.index(act_id), ctrl, stepper.layout.feedback_index(act_id, ctrl.feedback)))
    return plan


def controller_forces(plan, y: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """Step every controller on its signal in ``y_k``; write ``u_k`` into ``forces``."""
    item = y.item
    for pos, ctrl, idx in plan:
        forces[pos] = ctrl.step(item(idx))
    return forces


def feedforward_positions(stepper: PlantStepper, controllers: Mapping, feedforward) -> list[int]:
    """Positions in the force vector of the feed-forward block's actuators (none controlled)."""
    if feedforward is None:
        return []
    ids = [a.id for a in stepper.plant.actuators]
    both = sorted(set(feedforward.actuator_ids) & set(controllers))
    if both:
        raise ModelError(f"actuators {both} have a feedback controller and the feed-forward "
                         "generator; give each actuator one of them")
    missing = [a for a in feedforward.actuator_ids if a not in ids]
    if missing:
        raise ModelError(f"feed-forward actuators {missing} are not the plant's ({', '.join(ids)})")
    return [ids.index(a) for a in feedforward.actuator_ids]


def harmonic_forces(stepper: PlantStepper, controllers: Mapping, harmonic: Harmonic | None,
                    ff_pos=()):
    """``apply(y_k, forces)`` of a harmonic controller block (:class:`~rotor_avc.blocks.
    Harmonic`), or None without one: step the block on its signals in ``y_k`` and add its forces
    to ``forces`` (to the feedback or feed-forward force where the actuator has one; ``forces``
    starts from zero at each sample). Everything per sample is bound once, before the run."""
    if harmonic is None:
        return None
    ids = [a.id for a in stepper.plant.actuators]
    missing = [a for a in harmonic.actuator_ids if a not in ids]
    if missing:
        raise ModelError(f"harmonic actuators {missing} are not the plant's ({', '.join(ids)})")
    if abs(harmonic.sample_period_s - stepper.T) > 1e-12 * stepper.T:
        raise ModelError("the harmonic controller and the plant must share one sample rate")
    signals = [stepper.layout.index(name) for name in harmonic.sensors]
    take = itemgetter(*signals) if len(signals) > 1 else lambda y, i=signals[0]: (y[i],)
    positions = [ids.index(a) for a in harmonic.actuator_ids]
    step, speed_state = harmonic.step, stepper.speed_state

    def apply(y: np.ndarray, forces: list) -> None:
        speed, _, angle = speed_state()
        for p, f in zip(positions, step(take(y), angle, speed)):
            forces[p] += f
    return apply


def forces_from_answers(stepper: PlantStepper, answers: Mapping[str, float]) -> np.ndarray:
    """Force vector in plant actuator order from ``{actuator_id: force_n}`` (others zero)."""
    ids = [a.id for a in stepper.plant.actuators]
    forces = np.zeros(len(ids))
    for act_id, value in answers.items():
        if act_id not in ids:
            raise ModelError(f"a force for {act_id!r}, but the plant's actuators are "
                             + (", ".join(ids) or "none"))
        forces[ids.index(act_id)] = value
    return forces


def balancer_update(stepper: PlantStepper, balancer, k: int, y: np.ndarray) -> None:
    """Give the balancer sample ``k``; apply its correction from the next step on."""
    speed, accel, angle = stepper.speed_state()
    sample = LoopSample(k=k, t=stepper.time_s, angle=angle, speed=speed, accel=accel,
                        signals=y.copy(), names=tuple(stepper.layout.names))
    corr = balancer.step(sample)
    if corr is not None:
        stepper.set_correction(corr)


def start(stepper: PlantStepper, controllers: Mapping, initial_state: str = "rest",
          balancer=None) -> np.ndarray:
    """Reset every block; the plant at rest or on the loop's periodic steady state. -> ``y_0``"""
    if initial_state not in INITIAL_STATES:
        raise ModelError(f"unknown initial state {initial_state!r}; use one of {INITIAL_STATES}")
    if balancer is not None:
        balancer.reset()
    stepper.set_correction({})
    if initial_state == "steady_state":
        return start_in_steady_state(stepper, dict(controllers))
    for ctrl in controllers.values():
        ctrl.reset()
    return stepper.reset().copy()


# -- the run -------------------------------------------------------------------------------------
class Progress:
    """A one-line progress bar on stderr (only when enabled)."""

    def __init__(self, total: int, sample_period_s: float, enabled: bool):
        self.total, self.T, self.enabled = total, sample_period_s, enabled
        self.t0 = time.perf_counter()

    def update(self, k: int, final: bool = False) -> None:
        if not self.enabled:
            return
        wall = time.perf_counter() - self.t0
        frac = k / max(self.total, 1)
        bar = "#" * int(30 * frac)
        rtf = k * self.T / wall if wall > 0 else 0.0
        sys.stderr.write(f"\r[{bar:<30}] {100 * frac:5.1f} %  t = {k * self.T:8.3f} s  "
                         f"{rtf:6.1f}x real time")
        if final:
            sys.stderr.write("\n")
        sys.stderr.flush()


#: samples per block of a streamed run (:func:`run_blocks`): a few MB of signals per block
BLOCK_STEPS = 10_000


def run_loop(stepper: PlantStepper, controllers: Mapping, n_steps: int, **options) -> TimeSeries:
    """Run ``n_steps`` samples of the lockstep loop from ``t = 0``; return the time series.

    Options as :func:`run_blocks`; the whole run is one block, its size estimated first
    (:func:`check_run_memory`)."""
    check_run_memory(stepper, n_steps, options.get("balancer") is not None)
    (ts,) = run_blocks(stepper, controllers, n_steps, block_steps=max(n_steps, 1), **options)
    return ts


def check_run_memory(stepper: PlantStepper, n_steps: int, balancer: bool = False) -> None:
    """Refuse a run held in memory whose time series would exceed the memory limit.

    Per sample: the measurements, forces and corrections while running, then their channel
    copies, the four time axes and the test force (:func:`timeseries_from_run`)."""
    n_exc = len(stepper.plant.excitations) if balancer else 0
    per_sample = FLOAT_BYTES * (2 * (len(stepper.layout.names) + stepper.n_inputs + 2 * n_exc)
                                + len(stepper.plant.force_points) + 5)
    check_memory(per_sample * n_steps, f"a run of {n_steps} samples held in memory",
                 "write it to a .mcap bag (streamed, memory independent of the duration) or "
                 "shorten simulation.duration_s")


def run_blocks(stepper: PlantStepper, controllers: Mapping, n_steps: int, *,
               block_steps: int = BLOCK_STEPS, balancer: Balancer | None = None,
               feedforward: Synchronous | None = None, harmonic: Harmonic | None = None,
               initial_state: str = "rest", progress: bool | None = None,
               metadata: dict | None = None, stop=lambda: False,
               fast_path: bool = True) -> Iterator[TimeSeries]:
    """Run ``n_steps`` samples of the lockstep loop from ``t = 0``, yielding the time series in
    blocks of ``block_steps`` samples (memory independent of ``n_steps``).

    ``feedforward``: a synchronous force generator (rotor_avc.control.synchronous) whose forces
    drive its actuators (which then have no feedback controller), from the shaft angle and speed
    at ``t_k``.
    ``harmonic``: an adaptive harmonic controller block (rotor_avc.harmonic.block) whose forces
    add to those of the feedback controllers (:func:`harmonic_forces`).
    ``progress``: True/False, or None for "when stderr is a terminal and the run is long".
    ``stop``: called after each block; True ends the run there (e.g. on Ctrl-C).
    ``fast_path``: False steps every block on its own per-sample path (what the ROS graph
    does, message for message) even where :mod:`rotor_avc.sim.fused` could run."""
    if not isinstance(n_steps, int) or n_steps < 1:
        raise ModelError(f"the run needs at least one sample (got n_steps = {n_steps!r})")
    plan = control_plan(stepper, controllers)
    ff_pos = feedforward_positions(stepper, controllers, feedforward)
    h_apply = harmonic_forces(stepper, controllers, harmonic, ff_pos)
    if harmonic is not None:
        harmonic.reset()
    if feedforward is not None:
        feedforward.reset()
    if progress is None:
        progress = sys.stderr.isatty() and n_steps >= 50_000
    bar = Progress(n_steps, stepper.T, progress)
    y = start(stepper, controllers, initial_state, balancer)
    fast = (FusedLoop(stepper, plan, n_steps)
            if fast_path and feedforward is None and harmonic is None and balancer is None
            and fusable(controllers.values()) else None)
    zero = [0.0] * stepper.n_inputs     # u_k: a list, element writes cost a tenth of an array's
    step = stepper.step
    for k0 in range(0, n_steps, block_steps):
        n = min(block_steps, n_steps - k0)
        Y = np.empty((n, y.size))
        U = np.empty((n, stepper.n_inputs))
        C = np.zeros((n, len(stepper.plant.excitations)), complex) if balancer else None
        j = 0
        while j < n:
            if fast is not None and fast.pending:        # done on the fast path
                j += fast.emit(Y, U, j, n)
                continue
            k = k0 + j
            u = zero.copy()
            controller_forces(plan, y, u)
            if fast is not None:
                done, y = fast.run(y, u, Y, U, j, n, n_steps - k)
                if done:
                    j += done
                    bar.update(k0 + j)
                    continue
            Y[j] = y
            if feedforward is not None:
                speed, _, angle = stepper.speed_state()
                for pos, f in zip(ff_pos, feedforward.step(angle, speed)):
                    u[pos] = f
            if h_apply is not None:
                h_apply(y, u)
            U[j] = u
            if balancer is not None:
                balancer_update(stepper, balancer, k, y)
                C[j] = list(stepper.correction.values())
            y = step(u)
            j += 1
            if not k & 0x3FFF:
                bar.update(k)
        meta = dict(metadata or {})
        if harmonic is not None:
            meta["harmonic"] = {"controller": harmonic.describe(), "status": harmonic.status}
        yield timeseries_from_run(stepper, Y, U, C, meta, initial_state, controllers, k0)
        if stop():
            break
    bar.update(n_steps, final=True)


def timeseries_from_run(stepper, Y, U, C, metadata, initial_state, controllers,
                        first: int = 0) -> TimeSeries:
    """The recorded measurements ``Y``, forces ``U`` and corrections ``C`` of samples
    ``first, first + 1, ...`` as a time series."""
    n = Y.shape[0]
    t = (first + np.arange(n)) * stepper.T
    speed, accel, angle = stepper.profile.sample(t)
    lay = stepper.layout
    channels = {name: Y[:, i].copy() for i, name in enumerate(lay.names)}
    units = dict(lay.units)
    ids = [a.id for a in stepper.plant.actuators]
    for act_id, axis in stepper.plant.force_points:
        name = f"actuator_{act_id}_f{axis}"
        channels[name] = U[:, ids.index(act_id)].copy() if act_id in ids else np.zeros(n)
        units[name] = "N"
    test = stepper.test_force
    if test is not None:           # d_k, added to u_k by the stepper (rotor_avc.sim.broadband)
        channels[test.channel] = test.values(first, n)
        units[test.channel] = "N"
    if C is not None:                # the correction, as the balancer node's labelled arrays
        excitations = stepper.plant.excitations
        parts = np.stack([C.real, C.imag], axis=-1).reshape(len(C), -1)     # re, im per excitation
        for label, values, exc in zip(balancer_labels([e.name for e in excitations]), parts.T,
                                      [e for e in excitations for _ in ("re", "im")]):
            channels[f"balancer_{label}"] = values.copy()
            units[f"balancer_{label}"] = exc.unit
    meta = {"software": f"rotor_avc {__version__}", "plant": stepper.plant.name,
            "sample_period_s": stepper.T, "damping": stepper.damping.describe(),
            "initial_state": initial_state,
            "amplitudes": {k: [v.real, v.imag] for k, v in stepper.amplitudes.items()},
            "controllers": {k: getattr(c, "describe", lambda: repr(c))()
                            for k, c in controllers.items()},
            "speed_nodes": int(stepper.table.nodes.size)}
    if test is not None:
        meta["test_signal"] = test.describe()
    meta.update(metadata)
    return TimeSeries(t, speed, accel, angle, channels, units, meta)
