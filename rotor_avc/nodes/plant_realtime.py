"""The plant's real-time tick: samples taken on the wall-clock schedule and the check that
the graph holds the rate."""
from __future__ import annotations

import time

from ..sim.loop import forces_from_answers
from .plant_params import EXIT_NODE_LEFT, EXIT_RATE_NOT_HELD, RATE_CHECK_OVERRUNS, RATE_CHECK_S


class RealtimeMixin:
    """The real-time mode of :class:`rotor_avc.nodes.plant_simulator.PlantSimulator`."""

    # -- real time ------------------------------------------------------------------------------
    def _tick_realtime(self) -> None:
        """Take every sample that is due (absolute schedule: plant_simulator)."""
        if not self.started or self.finished:
            return
        now = time.perf_counter()
        while not self.finished and self.schedule.due(self.k) <= now:
            self._realtime_sample(now)
            now = time.perf_counter()

    def _realtime_sample(self, now: float) -> None:
        """Sample k in real time: the latest forces held, measurements published, one step.
        A controller silent for controller_timeout_s gets the fault policy (hold, zero: the
        samples are counted in the lockstep account) or, with ``wait``, ends the run."""
        wall = time.monotonic()
        for actuator, t_last in self.last_force_time.items():
            if self.book.expire(actuator, wall - (self.t_start if t_last is None else t_last)):
                if self.p["fault_policy"] == "wait":
                    reason = self.book.reason(actuator)
                    self.gone[actuator] = f"silent at sample {self.k}: {reason}"
                    self._fault(f"{self._who(actuator)}: {reason}; ending the run "
                                f"(exit status {EXIT_NODE_LEFT}; fault_policy hold or zero runs "
                                "on without it)")
                    self.exit_status = EXIT_NODE_LEFT
                    self._finish(complete=False)
                    return
                self._fault(f"{actuator}: {self.book.reason(actuator)}")
        if self.book.absent():
            self.book.substituted.add(self.k)
        u = forces_from_answers(self.stepper, {f: self.book.held(f, 0.0) for f in self.driven})
        self.schedule.record(self.k, now)
        self.timing.start()
        self._publish_sample()
        self.Y[self.k] = self.y
        self.U[self.k] = u
        self.y = self.stepper.step(u)
        self.k += 1
        self.timing.stop()
        if self.k >= self.n_steps:
            self._finish()
        elif self.k == self.rate_check_samples:
            self._check_rate()

    @property
    def rate_check_samples(self) -> int:
        return max(1, min(self.n_steps - 1, int(round(RATE_CHECK_S / self.T))))

    def _check_rate(self) -> None:
        """Real time, after the first RATE_CHECK_S: does the graph hold the rate?"""
        st = self.schedule.summary()
        share = self.schedule.overruns / max(self.schedule.n, 1)
        if share <= RATE_CHECK_OVERRUNS:
            return
        text = (f"real time at {1 / self.T:g} Hz is not held here: {100 * share:.0f} % of the "
                f"first {self.schedule.n} samples came more than a period late (lateness p50 "
                f"{1e6 * st['late_p50_s']:.0f} us, p99 {1e6 * st['late_p99_s']:.0f} us; tick "
                f"{1e6 * self.timing.summary().get('exec_mean_s', 0.0):.0f} us of "
                f"{1e6 * self.T:.0f} us) -- fix: a lower sample_rate_hz, a less loaded machine, "
                "or lockstep mode")
        if self.p["realtime_overload"] == "abort":
            self._fault(text + "; ending the run (exit status 3)")
            self.exit_status = EXIT_RATE_NOT_HELD
            self._finish(complete=False)
        else:
            self._fault(text + "; going on (realtime_overload: warn)")
