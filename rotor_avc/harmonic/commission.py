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

Margin (:func:`phase_margin`): per speed and harmonic, the largest phase error of the written
table that the adaptation tolerates -- the smaller of the quasi-steady limit with the identified
matrix as the machine (:func:`rotor_avc.harmonic.lti.robustness_map`; ``acos(mu / 2)`` for the
Newton law on an exact table) and the limit of the exact one-revolution map
(:func:`rotor_avc.harmonic.lti.harmonic_poles`) on the controller's model loop. The model only
supplies the loop's dynamics there: with the table exact for the machine, a model whose
influence is ``G_m`` stands for it through the input transform ``K = pinv(G_m) G_id`` (for the
Newton law and ``G_id`` of full row rank, ``K pinv(G_id) = pinv(G_m)``: the map equals the
model loop's with its own influence as the estimate), rotated by the phase error.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..analysis.order_tracking import fit
from ..errors import ModelError
from .influence import model_schedule
from .lti import harmonic_poles, robustness_map, samples_per_revolution

TWO_PI = 2 * math.pi
#: phase errors of the quasi-steady limit (deg) and bisection steps of the exact one
PHASES_DEG = np.arange(-180.0, 180.5, 0.5)
BISECTIONS = 8


class TestSequence:
    """The test phasors as a block of the loop (module docstring): ``reset()``,
    ``step(signals, angle, speed) -> forces``; ``finished`` once measured (or stopped:
    ``failure``), its results in :attr:`responses` (H, M, N) and :attr:`levels_n` (H, N)."""

    def __init__(self, sensors, actuators, harmonics, sample_period_s: float, test_force_n: float,
                 settings, max_added=None, name: str = "commission"):
        self.sensors, self.actuator_ids = tuple(sensors), tuple(actuators)
        self.harmonics = tuple(int(h) for h in harmonics)
        self.sample_period_s = float(sample_period_s)
        self.test_force_n = float(test_force_n)
        self.settings = settings
        self.max_added = max_added
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
        x = min((angle - self._ramp_start) / (TWO_PI * self.settings.ramp_revolutions), 1.0)
        self._applied = self._from + (self.target - self._from) * 0.5 * (1 - math.cos(math.pi * x))
        return (self._applied * np.exp(1j * self._h * angle)).real.sum(axis=0).tolist()

    def _fade_to(self, target: np.ndarray) -> None:
        self._from, self.target = self._applied.copy(), target
        self._ramp_start = self._now
        self.phase, self.revs = "ramp", 0

    def _revolution(self) -> None:
        """One revolution ended: its phasors, the added-vibration check, the sequence."""
        theta = np.array(self._angles)
        y = np.array(self._values)
        self._angles, self._values = [], []
        if self.finished:
            return
        E = np.array([fit(h * theta, y)[0] for h in self.harmonics])        # (H, M)
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
            self.failure = f"{what} at {self.levels_n[hi, j]:.3g} N after " \
                           f"{self.retries[hi, j]} halvings"
            self.finished = True
            self._fade_to(np.zeros_like(self.target))
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


def run_test(scenario, sequence: TestSequence) -> TestSequence:
    """Run the test sequence on the scenario's machine (its feedback controllers closed, its
    own harmonic control off) until it has finished; the sequence, with its results."""
    from ..sim.loop import run_blocks
    speed = scenario.profile.max_speed_rad_s
    per_rev = TWO_PI / (speed * scenario.sample_period_s)
    n = int(math.ceil(sequence.max_revolutions() * per_rev))
    for _ in run_blocks(scenario.stepper(), scenario.controllers(), n, harmonic=sequence,
                        feedforward=scenario.feedforward(), initial_state=scenario.initial_state,
                        block_steps=max(int(per_rev * 5), 100), progress=False,
                        stop=lambda: sequence.finished):
        pass
    if not sequence.finished:
        raise ModelError("the test sequence did not finish within its planned length")
    return sequence


@dataclass(frozen=True)
class Margin:
    """Phase margins (deg) per harmonic: quasi-steady with the identified matrix, of the exact
    one-revolution map (and its spectral radius with the table exact), at ``speed_rad_s``."""

    speed_rad_s: float
    quasi_steady_deg: tuple[float, ...]
    exact_deg: float
    radius: float
    model: np.ndarray                   # (H, M, N): the model's influence at that speed

    @property
    def phase_margin_deg(self) -> float:
        return float(min(min(self.quasi_steady_deg), self.exact_deg))


def phase_margin(loop, speed_rad_s: float, w_F: float | None, actuators, sensors, harmonics,
                 identified: np.ndarray, law: str, gain: float, *, effort_weight: float = 0.0,
                 leakage: float = 0.0, sensor_weights=None) -> Margin:
    """:class:`Margin` at the speed moved to a whole number of samples per revolution (the map
    needs it; module docstring); ``loop`` the controller's model loop."""
    T = loop.sample_period_s
    w = TWO_PI / (max(int(round(TWO_PI / (speed_rad_s * T))), 3) * T)
    samples_per_revolution(w, T)
    wf = w if w_F is None else w_F
    qs = []
    for G in identified:
        if np.linalg.matrix_rank(G) < min(G.shape):
            qs.append(0.0)
            continue
        limit = robustness_map(G, law, PHASES_DEG, [1.0], [gain], effort_weight=effort_weight,
                               leakage=leakage).phase_limit_deg()[0, 0]
        qs.append(0.0 if np.isnan(limit) else float(limit))
    model = model_schedule(loop, sensors, actuators, harmonics, [w], wf).matrices[0]
    lwi = loop.with_inputs(w, wf, actuators, sensors)

    def radius(phase_deg: float) -> float:
        est = model * np.exp(1j * np.deg2rad(phase_deg))
        return harmonic_poles(loop, w, wf, actuators, sensors, harmonics, est, law, gain,
                              effort_weight=effort_weight, leakage=leakage,
                              sensor_weights=sensor_weights, lwi=lwi).max_abs_z

    r0 = radius(0.0)
    exact = 0.0 if r0 >= 1.0 else min(_stable_phase(radius, sign, max(qs))
                                      for sign in (1.0, -1.0))
    return Margin(w, tuple(qs), exact, r0, model)


def _stable_phase(radius, sign: float, top: float) -> float:
    """The largest phase error in ``[0, top]`` (one sign) up to which ``radius < 1`` (bisection
    from a stable zero)."""
    if top <= 0 or radius(sign * top) < 1.0:
        return top
    lo, hi = 0.0, top
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if radius(sign * mid) < 1.0 else (lo, mid)
    return lo


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


def commission(data: dict, source: str, make_scenario, model_machine=None, speeds_hz=None,
               **overrides) -> Commissioning:
    """Commission the ``harmonic:`` section of the scenario ``data`` (a merged config) on its
    machine: the test at each of ``speeds_hz`` (default: the scenario's constant speed), the
    margin on ``model_machine``'s loop (default: the scenario's machine); ``overrides``:
    ``harmonic.commission`` keys given on the command line. ``make_scenario(data, source)``
    builds a :class:`rotor_avc.scenario.Scenario`."""
    import copy
    from dataclasses import replace
    from ..analysis.sampled_loop import machine_sampled_loop
    from .config import AUTO_GAINS, harmonic_actuators, harmonic_section, harmonic_sensors
    scenario = make_scenario(data, source)
    machine = scenario.machine
    cfg = machine.config
    if not cfg.has("harmonic"):
        raise cfg.error("harmonic", "missing: commissioning identifies the influence matrix of "
                        "the `harmonic:` section", fix="include a harmonic config (e.g. "
                        "harmonic_bearings.yaml)")
    sec = cfg.section("harmonic")
    s = harmonic_section(cfg)
    cs = replace(s.commission, **{k: v for k, v in overrides.items() if v is not None})
    actuators, sensors = harmonic_actuators(machine), harmonic_sensors(machine)
    harmonics = tuple(int(h) for h in sorted(s.harmonics))
    if speeds_hz is None:
        speed = data.get("simulation", {}).get("speed", {})
        if speed.get("type") != "constant":
            raise cfg.section("simulation").error("speed", "commissioning tests at constant "
                                                  "speeds; this profile is not constant",
                                                  fix="give the speeds (--speed-hz F[,F...])")
        speeds_hz = [float(speed["speed_hz"])]
    limits = {a: (machine.controller_settings[a].force_limit_n,
                  machine.controller_settings[a].rate_limit_n_per_s)
              for a in actuators if a in machine.controller_settings}
    check_test_level(sec, cs.test_force_n, harmonics, [TWO_PI * f for f in speeds_hz],
                     s.force_limit_n, s.rate_limit_n_per_s, limits)
    T = scenario.sample_period_s
    loop = machine_sampled_loop(model_machine or machine, T)
    w_F = scenario.damping.whirl_rad_s
    results = []
    for f in speeds_hz:
        run = copy.deepcopy(data)
        run.setdefault("simulation", {}).update(speed={"type": "constant", "speed_hz": f},
                                                harmonic=False)
        seq = run_test(make_scenario(run, source),
                       TestSequence(sensors, actuators, harmonics, T, cs.test_force_n, cs))
        if seq.failure is not None:
            return Commissioning(tuple(sensors), tuple(actuators), harmonics, tuple(results),
                                 cs.min_phase_margin_deg, seq.failure)
        gain = s.gain
        if gain == "auto":
            from .lti import gain_schedule
            sched = model_schedule(loop, sensors, actuators, harmonics, [TWO_PI * f], w_F)
            gain = gain_schedule(loop, sched, s, [TWO_PI * f], AUTO_GAINS, w_F)[1][0]
        margin = phase_margin(loop, TWO_PI * f, w_F, actuators, sensors, harmonics,
                              seq.responses, s.law, gain, effort_weight=s.effort_weight,
                              leakage=s.leakage, sensor_weights=s.sensor_weights)
        results.append(SpeedCommission(f, seq.responses, seq.levels_n, seq.settling, margin,
                                       tuple(seq.log)))
    return Commissioning(tuple(sensors), tuple(actuators), harmonics, tuple(results),
                         cs.min_phase_margin_deg)
