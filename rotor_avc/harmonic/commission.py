"""Commissioning adaptive harmonic control: the influence matrix identified on the machine with
test phasors, and the margin of the loop that will adapt with it, before adaptation is enabled.

The test (:class:`TestSequence`, a block of the loop like :class:`.block.HarmonicController`) runs
at a constant speed with harmonic control off: a baseline, then per harmonic ``h`` and actuator
``j`` one test phasor ``a_hj`` (real, peak force ``a``) faded in over ``ramp_revolutions``
(raised cosine, from the previous test's force), held ``settle_revolutions``, and measured over
``measure_revolutions``. Every revolution's 1x (nx) phasors come from the order-tracking fit
(:func:`rotor_avc.analysis.order_tracking.fit` at the angle ``h theta``); the column is::

    G_h[:, j] = (mean E_h(test hj) - mean E_h(baseline)) / a_hj

the influence of :mod:`.influence` (the force samples' phasor in, the sensor samples' out).
Added vibration is bounded: when a sensor's phasor magnitude rises more than
``max_added_vibration`` above its level before the test (default: that level), the test
level is halved and faded in again, at most ``max_retries`` times, else the test stops with the
reason. ``settling`` is how far the measured column still moves: the difference of its means
over the two halves of the measured revolutions, relative to it.

The margin before adapting: :mod:`.commission_margin`. :class:`Plan` is what a scenario's
commissioning needs, validated once; :func:`commission` runs it in-process at each speed,
:class:`.commission_block.CommissioningBlock` on live signals (the ROS node).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..analysis.order_tracking import fit
from ..errors import ModelError
from .commission_margin import Margin, phase_margin
from .influence import model_schedule

TWO_PI = 2 * math.pi


class TestSequence:
    """The test phasors as a block of the loop (module docstring): ``reset()``,
    ``step(signals, angle, speed) -> forces``; ``finished`` once measured (or stopped:
    ``failure``), ``idle`` once the last test phasor has faded out too; its results in
    :attr:`responses` (H, M, N) and :attr:`levels_n` (H, N); per revolution :attr:`E` (H, M)
    and :attr:`revolutions`, :meth:`progress` the step it is at."""

    def __init__(self, sensors, actuators, harmonics, sample_period_s: float, test_force_n: float,
                 settings, name: str = "commission"):
        self.sensors, self.actuator_ids = tuple(sensors), tuple(actuators)
        self.harmonics = tuple(int(h) for h in harmonics)
        self.sample_period_s = float(sample_period_s)
        self.test_force_n = float(test_force_n)
        self.settings = settings
        self.name = name
        self._h = np.array(self.harmonics, dtype=float)[:, None]
        self._stages = [None] + [(hi, j) for hi in range(len(self.harmonics))
                                 for j in range(len(self.actuator_ids))]
        self.reset()

    def reset(self) -> None:
        H, M, N = len(self.harmonics), len(self.sensors), len(self.actuator_ids)
        self.levels_n = np.full((H, N), self.test_force_n)
        self.retries = np.zeros((H, N), int)
        self.responses = np.zeros((H, M, N), complex)
        self.settling = np.zeros((H, N))
        self.baseline = np.zeros((H, M), complex)
        self.limit = np.zeros(M)
        self.stage, self.phase, self.revs = 0, "ramp", 0
        self.target = np.zeros((H, N), complex)
        self._from = np.zeros((H, N), complex)
        self._applied = np.zeros((H, N), complex)
        self._ramp_start = self._rev_start = self._now = None
        self._x = 0.0
        self.E = np.zeros((H, M), complex)
        self.revolutions = 0
        self._angles: list[float] = []
        self._values: list = []
        self._measured: list[np.ndarray] = []
        self.finished = False
        self.failure: str | None = None
        self.log: list[str] = []

    @property
    def status(self) -> dict:
        return {"stage": self.stage, "phase": self.phase, "finished": self.finished,
                "failure": self.failure, "levels_n": self.levels_n.tolist()}

    def describe(self) -> str:
        return (f"{self.name}: test phasors of {self.test_force_n:g} N, one of "
                f"{len(self.actuator_ids)} actuators at a time, harmonics {list(self.harmonics)}")

    @property
    def steps(self) -> int:
        """Steps of the sequence: the baseline and one test per harmonic and actuator."""
        return len(self._stages)

    @property
    def phasors(self) -> np.ndarray:
        """The test phasors applied at the last sample (H, N), N peak."""
        return self._applied

    @property
    def idle(self) -> bool:
        """Finished, and the last test phasor faded out (the forces are zero from now on)."""
        return self.finished and self._x >= 1.0

    def progress(self) -> str:
        """``step i of n: <baseline | actuator at hx, level>, <phase> r/R revolutions``, or
        how the sequence ended."""
        if self.finished:
            return f"stopped: {self.failure}" if self.failure else "every test measured"
        s = self.settings
        total = {"ramp": s.ramp_revolutions, "settle": s.settle_revolutions,
                 "measure": s.measure_revolutions}[self.phase]
        current = self._stages[self.stage]
        what = "baseline" if current is None else (
            f"{self.actuator_ids[current[1]]} at {self.harmonics[current[0]]}x, "
            f"{self.levels_n[current]:.3g} N")
        return (f"step {self.stage + 1} of {self.steps}: {what}, {self.phase} "
                f"{self.revs}/{total} revolutions")

    def stop(self, failure: str) -> None:
        """End the sequence with ``failure``, fading the running test phasor out."""
        self.failure = failure
        self.finished = True
        self._fade_to(np.zeros_like(self.target))

    def step(self, signals, angle: float, speed: float) -> list[float]:
        """Sensor signals at ``t_k``, shaft angle (rad), speed (rad/s) -> forces (N)."""
        self._now = angle
        if self._rev_start is None:
            self._rev_start = self._ramp_start = angle
        elif angle - self._rev_start >= TWO_PI * (1 - 1e-12):
            self._revolution()
            self._rev_start = angle
        self._angles.append(angle)
        self._values.append(list(signals))
        x = self._x = min((angle - self._ramp_start) / (TWO_PI * self.settings.ramp_revolutions),
                          1.0)
        self._applied = self._from + (self.target - self._from) * 0.5 * (1 - math.cos(math.pi * x))
        return (self._applied * np.exp(1j * self._h * angle)).real.sum(axis=0).tolist()

    def _fade_to(self, target: np.ndarray) -> None:
        self._from, self.target = self._applied.copy(), target
        self._ramp_start = self._now
        self._x = 0.0
        self.phase, self.revs = "ramp", 0

    def _revolution(self) -> None:
        """One revolution ended: its phasors, the added-vibration check, the sequence."""
        theta = np.array(self._angles)
        y = np.array(self._values)
        self._angles, self._values = [], []
        if self.finished:
            return
        E = self.E = np.array([fit(h * theta, y)[0] for h in self.harmonics])   # (H, M)
        self.revolutions += 1
        current = self._stages[self.stage]
        if current is not None and self._too_much(E, current):
            return
        self.revs += 1
        s = self.settings
        if self.phase == "ramp" and self.revs >= s.ramp_revolutions:
            self.phase, self.revs = "settle", 0
        elif self.phase == "settle" and self.revs >= s.settle_revolutions:
            self.phase, self.revs = "measure", 0
        elif self.phase == "measure":
            self._measured.append(E)
            if self.revs >= s.measure_revolutions:
                self._stage_done(current)

    def _too_much(self, E: np.ndarray, current) -> bool:
        """Halve the running test (or stop the sequence) when a sensor's 1x rose too far."""
        rise = (np.abs(E) - np.abs(self.baseline)).max(axis=0)               # (M,)
        over = np.flatnonzero(rise > self.limit)
        if not over.size:
            return False
        hi, j = current
        i = int(over[np.argmax(rise[over] / self.limit[over])])
        what = (f"{self.actuator_ids[j]} at {self.harmonics[hi]}x: the {self.sensors[i]} level "
                f"rose {rise[i]:.3g} above its {np.abs(self.baseline[:, i]).max():.3g} before "
                f"the test, more than {self.limit[i]:.3g} (max_added_vibration)")
        if self.retries[hi, j] >= self.settings.max_retries:
            self.stop(f"{what} at {self.levels_n[hi, j]:.3g} N after {self.retries[hi, j]} "
                      "halvings")
            return True
        self.retries[hi, j] += 1
        self.levels_n[hi, j] /= 2
        self.log.append(f"{what}: test level halved to {self.levels_n[hi, j]:.3g} N")
        self._measured = []
        target = np.zeros_like(self.target)
        target[hi, j] = self.levels_n[hi, j]
        self._fade_to(target)
        return True

    def _stage_done(self, current) -> None:
        runs = np.array(self._measured)                                       # (R, H, M)
        self._measured = []
        mean = runs.mean(axis=0)
        if current is None:
            self.baseline = mean
            given = self.settings.max_added_vibration
            self.limit = np.full(len(self.sensors), given) if given is not None \
                else np.abs(mean).max(axis=0)
        else:
            hi, j = current
            added = mean[hi] - self.baseline[hi]
            half = runs.shape[0] // 2
            moved = runs[half:, hi].mean(axis=0) - runs[:half, hi].mean(axis=0)
            self.responses[hi, :, j] = added / self.levels_n[hi, j]
            self.settling[hi, j] = float(np.linalg.norm(moved) /
                                         max(np.linalg.norm(added), 1e-300))
        self.stage += 1
        target = np.zeros_like(self.target)
        if self.stage < len(self._stages):
            hi, j = self._stages[self.stage]
            target[hi, j] = self.levels_n[hi, j]
        else:
            self.finished = True
        self._fade_to(target)

    def max_revolutions(self) -> int:
        """Revolutions the sequence can take at most (every test halved every time)."""
        s = self.settings
        per_stage = s.ramp_revolutions + s.settle_revolutions + s.measure_revolutions
        return len(self._stages) * per_stage * (1 + s.max_retries) + s.ramp_revolutions + 2


def run_test(scenario, sequence: TestSequence, progress=None) -> TestSequence:
    """Run the test sequence on the scenario's machine (its feedback controllers closed, its
    own harmonic control off) until it has finished; the sequence, with its results.
    ``progress``: called with the steps done after each block of samples (None: quiet)."""
    from ..sim.loop import run_blocks
    speed = scenario.profile.max_speed_rad_s
    per_rev = TWO_PI / (speed * scenario.sample_period_s)
    n = int(math.ceil(sequence.max_revolutions() * per_rev))
    for _ in run_blocks(scenario.stepper(), scenario.controllers(), n, harmonic=sequence,
                        feedforward=scenario.feedforward(), initial_state=scenario.initial_state,
                        block_steps=max(int(per_rev * 5), 100), progress=False,
                        stop=lambda: sequence.finished):
        if progress is not None:
            progress(sequence.stage)
    if not sequence.finished:
        raise ModelError("the test sequence did not finish within its planned length")
    return sequence


def check_test_level(sec, level_n: float, harmonics, speeds_rad_s, force_limit_n,
                     rate_limit_n_per_s, actuator_limits: dict) -> None:
    """ConfigError naming the limit a test phasor of peak ``level_n`` would exceed: the
    harmonic section's force and slope limits, and each actuator's feedback limits
    (``actuator_limits``: ``{id: (force_limit_n, rate_limit_n_per_s)}``, None: none)."""
    fix = "lower harmonic.commission.test_force_n (or --test-force-n)"
    if force_limit_n is not None and level_n > force_limit_n:
        raise sec.error("commission.test_force_n", f"{level_n:g} N is above force_limit_n "
                        f"{force_limit_n:g} N", fix=fix)
    slope = level_n * max(harmonics) * max(speeds_rad_s)
    if rate_limit_n_per_s is not None and slope > rate_limit_n_per_s:
        raise sec.error("commission.test_force_n", f"{level_n:g} N at {max(harmonics)}x "
                        f"{max(speeds_rad_s) / TWO_PI:g} Hz slopes {slope:.4g} N/s, above "
                        f"rate_limit_n_per_s {rate_limit_n_per_s:g} N/s", fix=fix)
    for act, (force, rate) in actuator_limits.items():
        if force is not None and level_n > force:
            raise sec.error("commission.test_force_n", f"{level_n:g} N is above "
                            f"controllers.{act}.force_limit_n {force:g} N", fix=fix)
        if rate is not None and slope > rate:
            raise sec.error("commission.test_force_n", f"{level_n:g} N slopes {slope:.4g} N/s, "
                            f"above controllers.{act}.rate_limit_n_per_s {rate:g} N/s", fix=fix)


def table_entries(speed_hz: float, harmonics, sensors, actuators, matrices) -> list[dict]:
    """``harmonic.influence.table`` entries of one speed's matrices (H, M, N)."""
    return [{"speed_hz": float(speed_hz), "harmonic": int(h), "sensor": s, "actuator": a,
             "re": float(matrices[hi, i, j].real), "im": float(matrices[hi, i, j].imag)}
            for hi, h in enumerate(harmonics) for i, s in enumerate(sensors)
            for j, a in enumerate(actuators)]


@dataclass(frozen=True)
class SpeedCommission:
    """What one speed's test found: the identified matrices (H, M, N), the test levels (H, N)
    they were measured at, their settling, the margin, and the halvings' log."""

    speed_hz: float
    identified: np.ndarray
    levels_n: np.ndarray
    settling: np.ndarray
    margin: Margin
    log: tuple[str, ...]


@dataclass(frozen=True)
class Commissioning:
    """Every speed's result; ``failure`` when a test stopped (then no later speed was tested)."""

    sensors: tuple[str, ...]
    actuators: tuple[str, ...]
    harmonics: tuple[int, ...]
    speeds: tuple[SpeedCommission, ...]
    min_phase_margin_deg: float
    failure: str | None = None

    @property
    def phase_margin_deg(self) -> float:
        return min((r.margin.phase_margin_deg for r in self.speeds), default=float("nan"))

    @property
    def refusal(self) -> str | None:
        """Why adapting is refused (one line), or None."""
        if self.failure is not None:
            return f"the test stopped: {self.failure}"
        worst = min(self.speeds, key=lambda r: r.margin.phase_margin_deg)
        m = worst.margin
        if m.phase_margin_deg >= self.min_phase_margin_deg:
            return None
        return (f"phase margin {m.phase_margin_deg:.1f} deg at {worst.speed_hz:g} Hz is below "
                f"harmonic.commission.min_phase_margin_deg {self.min_phase_margin_deg:g} deg "
                f"(quasi-steady {min(m.quasi_steady_deg):.1f} deg, exact one-revolution map "
                f"{m.exact_deg:.1f} deg, radius {m.radius:.4f})")

    def table(self) -> list[dict]:
        """The ``harmonic.influence.table`` of every speed."""
        return [e for r in self.speeds for e in table_entries(
            r.speed_hz, self.harmonics, self.sensors, self.actuators, r.identified)]


@dataclass(frozen=True)
class Plan:
    """What commissioning a scenario's ``harmonic:`` section needs, validated once
    (:func:`plan`): its settings, the test settings with the overrides, sensors, actuators and
    harmonics, the controller's model loop of the margin and the feedback limits of the
    actuators. :func:`commission` drives it in-process, :class:`.commission_block.
    CommissioningBlock` on live signals: one procedure."""

    section: object                     # the `harmonic:` Section (errors name its keys)
    settings: object                    # HarmonicControlSettings
    commission: object                  # CommissionSettings, with the overrides
    sensors: tuple[str, ...]
    actuators: tuple[str, ...]
    harmonics: tuple[int, ...]
    loop: object                        # the model's SampledLoop
    w_F: float | None
    sample_period_s: float
    actuator_limits: dict

    def check_level(self, speeds_hz) -> None:
        """ConfigError when a test phasor would exceed a limit at one of ``speeds_hz``
        (:func:`check_test_level`), before any is applied."""
        s = self.settings
        check_test_level(self.section, self.commission.test_force_n, self.harmonics,
                         [TWO_PI * f for f in speeds_hz], s.force_limit_n, s.rate_limit_n_per_s,
                         self.actuator_limits)

    def sequence(self) -> TestSequence:
        return TestSequence(self.sensors, self.actuators, self.harmonics, self.sample_period_s,
                            self.commission.test_force_n, self.commission)

    def speed_result(self, speed_hz: float, seq: TestSequence) -> SpeedCommission:
        """A finished test's result at ``speed_hz``: its matrices and the margin of the
        adaptation with them (``gain: auto``: the gain the loop analysis gives there)."""
        from .config import AUTO_GAINS
        s, w = self.settings, TWO_PI * speed_hz
        gain = s.gain
        if gain == "auto":
            from .lti import gain_schedule
            sched = model_schedule(self.loop, self.sensors, self.actuators, self.harmonics, [w],
                                   self.w_F)
            gain = gain_schedule(self.loop, sched, s, [w], AUTO_GAINS, self.w_F)[1][0]
        margin = phase_margin(self.loop, w, self.w_F, self.actuators, self.sensors,
                              self.harmonics, seq.responses, s.law, gain,
                              effort_weight=s.effort_weight, leakage=s.leakage,
                              sensor_weights=s.sensor_weights)
        return SpeedCommission(speed_hz, seq.responses, seq.levels_n, seq.settling, margin,
                               tuple(seq.log))

    def result(self, speeds, failure: str | None = None) -> Commissioning:
        return Commissioning(self.sensors, self.actuators, self.harmonics, tuple(speeds),
                             self.commission.min_phase_margin_deg, failure)


def plan(scenario, model_machine=None, **overrides) -> Plan:
    """The :class:`Plan` of the scenario's ``harmonic:`` section; the margin on
    ``model_machine``'s loop (default: the scenario's machine); ``overrides``:
    ``harmonic.commission`` keys given on the command line (None: the config's)."""
    from dataclasses import replace
    from ..analysis.sampled_loop import machine_sampled_loop
    from .config import harmonic_actuators, harmonic_section, harmonic_sensors
    machine = scenario.machine
    cfg = machine.config
    if not cfg.has("harmonic"):
        raise cfg.error("harmonic", "missing: commissioning identifies the influence matrix of "
                        "the `harmonic:` section", fix="include a harmonic config (e.g. "
                        "harmonic_bearings.yaml)")
    s = harmonic_section(cfg)
    actuators = tuple(harmonic_actuators(machine))
    limits = {a: (machine.controller_settings[a].force_limit_n,
                  machine.controller_settings[a].rate_limit_n_per_s)
              for a in actuators if a in machine.controller_settings}
    T = scenario.sample_period_s
    return Plan(cfg.section("harmonic"), s,
                replace(s.commission, **{k: v for k, v in overrides.items() if v is not None}),
                tuple(harmonic_sensors(machine)), actuators,
                tuple(int(h) for h in sorted(s.harmonics)),
                machine_sampled_loop(model_machine or machine, T), scenario.damping.whirl_rad_s,
                T, limits)


def constant_speed_hz(scenario, fix: str) -> float:
    """The scenario's constant speed (Hz), as its config gives it; ConfigError with ``fix``
    for another profile."""
    cfg = scenario.machine.config
    speed = cfg.data.get("simulation", {}).get("speed", {})
    if speed.get("type") != "constant":
        raise cfg.section("simulation").error("speed", "commissioning tests at constant speeds; "
                                              "this profile is not constant", fix=fix)
    return float(speed["speed_hz"])


def commission(data: dict, source: str, make_scenario, model_machine=None, speeds_hz=None,
               progress=None, **overrides) -> Commissioning:
    """Commission the ``harmonic:`` section of the scenario ``data`` (a merged config) on its
    machine: the test at each of ``speeds_hz`` (default: the scenario's constant speed; the
    machine running steadily there, harmonic control off), the
    margin on ``model_machine``'s loop (default: the scenario's machine); ``overrides``:
    ``harmonic.commission`` keys given on the command line. ``make_scenario(data, source)``
    builds a :class:`rotor_avc.scenario.Scenario`; ``progress``: called ``(steps done, steps)``
    over every speed's baseline and tests (None: quiet)."""
    import copy
    scenario = make_scenario(data, source)
    p = plan(scenario, model_machine, **overrides)
    if speeds_hz is None:
        speeds_hz = [constant_speed_hz(scenario, "give the speeds (--speed-hz F[,F...])")]
    p.check_level(speeds_hz)
    results = []
    for i, f in enumerate(speeds_hz):
        seq = p.sequence()
        steps = None if progress is None else (
            lambda done, n=seq.steps, i=i: progress(i * n + done, len(speeds_hz) * n))
        run = copy.deepcopy(data)
        run.setdefault("simulation", {}).update(
            speed={"type": "constant", "speed_hz": f}, harmonic=False, initial_state="steady_state",
            duration_s=seq.max_revolutions() / f)
        seq = run_test(make_scenario(run, source), seq, steps)
        if seq.failure is not None:
            return p.result(results, seq.failure)
        results.append(p.speed_result(f, seq))
    return p.result(results)
