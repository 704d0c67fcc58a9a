"""Commissioning on live signals: the harmonic controller node's ``commission`` mode as one block
of the loop (:class:`rotor_avc.blocks.Harmonic`), driving the procedure of :mod:`.commission`
(its :class:`.commission.Plan` and :class:`.commission.TestSequence`, the ones the in-process
``rotor-avc harmonic commission`` runs) sample by sample:

1. zero force until the shaft turns within ``SPEED_TOLERANCE`` of the commissioning speed (the
   scenario's constant speed, at which the test level was checked against the limits);
2. the test sequence (baseline, one test phasor per harmonic and actuator, the added-vibration
   bound); a speed leaving that band stops it, with the reason;
3. once measured: the result (:meth:`.commission.Plan.speed_result`: the identified matrices and
   the margin) is handed once to ``finish(result)``, which writes it and, when it is accepted,
   returns the block to adapt with (the harmonic controller on the identified table);
   refused (``result.refusal``, or the margin or ``finish`` raised) the block stays at zero
   force (after the last test phasor's fade-out) and keeps the reason;
4. accepted: after the last test phasor has faded out, every later sample goes to that block
   (its ``harmonic.start_s`` counted from the switch).

:attr:`mode` extends the controller's modes (:data:`.block.MODES`) by ``commissioning`` and
``refused``; :attr:`n_updates` counts the test's revolutions, then adds the block's updates.
"""
from __future__ import annotations

import math

from ..errors import RotorAvcError
from .block import MODES as BLOCK_MODES

MODES = BLOCK_MODES + ("commissioning", "refused")
#: relative band around the commissioning speed in which the test runs
SPEED_TOLERANCE = 0.01
TWO_PI = 2 * math.pi


class CommissioningBlock:
    """``reset()`` / ``step(signals, angle, speed) -> forces`` (module docstring); ``plan`` a
    :class:`.commission.Plan`, ``speed_hz`` the commissioning speed, ``finish(result)`` the
    accepted result's block (None when refused)."""

    def __init__(self, plan, speed_hz: float, finish, name: str = "commissioning"):
        plan.check_level([speed_hz])
        self.plan, self.speed_hz, self.finish, self.name = plan, float(speed_hz), finish, name
        self.sensors, self.actuator_ids = plan.sensors, plan.actuators
        self.harmonics, self.sample_period_s = plan.harmonics, plan.sample_period_s
        self._w = TWO_PI * self.speed_hz
        self._zero = [0.0] * len(self.actuator_ids)
        self.reset()

    def reset(self) -> None:
        self.sequence = self.plan.sequence()
        self.block = self._next = self.result = self.refusal = None
        self.started = False

    # -- what it reports -----------------------------------------------------------------------
    @property
    def mode(self) -> str:
        if self.block is not None:
            return self.block.mode
        return "refused" if self.refusal is not None else "commissioning"

    @property
    def n_updates(self) -> int:
        return self.sequence.revolutions + (self.block.n_updates if self.block is not None else 0)

    @property
    def E(self):
        return self.block.E if self.block is not None else self.sequence.E

    @property
    def U(self):
        return self.block.U if self.block is not None else self.sequence.phasors

    def progress(self) -> str:
        """One line: where the commissioning is, or why it was refused."""
        if self.refusal is not None:
            return f"refused: {self.refusal}"
        if not self.started:
            return f"waiting for {self.speed_hz:g} Hz (+-{100 * SPEED_TOLERANCE:g} %)"
        if self.result is not None:
            return (f"accepted: phase margin {self.result.phase_margin_deg:.1f} deg; "
                    + ("adapting with the identified table" if self.block is not None
                       else "the last test phasor fading out"))
        return self.sequence.progress()

    @property
    def status(self) -> dict:
        seq = self.sequence
        own = {"progress": self.progress(), "step": min(seq.stage + 1, seq.steps),
               "steps": seq.steps, "test_force_n": seq.levels_n.tolist(),
               "phase_margin_deg": (None if self.result is None or not self.result.speeds
                                    else self.result.phase_margin_deg)}
        if self.block is not None:
            return {**self.block.status, "commissioning": own}
        return {"mode": self.mode, "reason": self.progress(), "updates": self.n_updates,
                "saturated": False, "fallbacks": 0, "commissioning": own}

    def describe(self) -> str:
        text = f"{self.name} at {self.speed_hz:g} Hz: {self.sequence.describe()}"
        return text if self.block is None else f"{text}; then {self.block.describe()}"

    # -- stepping ----------------------------------------------------------------------------
    def step(self, signals, angle: float, speed: float) -> list[float]:
        """Sensor signals at ``t_k``, shaft angle (rad), speed (rad/s) -> forces (N)."""
        if self.block is not None:
            return self.block.step(signals, angle, speed)
        seq = self.sequence
        if not seq.finished:
            inside = abs(speed - self._w) <= SPEED_TOLERANCE * self._w
            if not self.started:
                if not inside:
                    return self._zero
                self.started = True
            elif not inside:
                seq.stop(f"the speed left {self.speed_hz:g} Hz +-{100 * SPEED_TOLERANCE:g} % "
                         f"({speed / TWO_PI:.4g} Hz)")
        forces = seq.step(signals, angle, speed)
        if seq.finished and self.result is None:
            self._conclude()
        if self._next is not None and seq.idle:
            self.block, self._next = self._next, None
        return forces

    def _conclude(self) -> None:
        """The test ended: its result, handed to ``finish``; refused or the block to come."""
        seq, plan = self.sequence, self.plan
        try:
            self.result = (plan.result([], seq.failure) if seq.failure is not None
                           else plan.result([plan.speed_result(self.speed_hz, seq)]))
            block = self.finish(self.result)
        except RotorAvcError as exc:
            self.result = self.result or plan.result([], str(exc))
            self.refusal = f"the margin or the commissioned config: {exc}"
            return
        self.refusal = self.result.refusal
        if self.refusal is None:
            self._next = block
