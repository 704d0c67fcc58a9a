"""Simulation scenarios: a machine config plus a ``simulation:`` section, validated, and run --
the composition root that wires the machine, its controllers, balancer and feed-forward into the
lockstep loop.

A scenario file includes a machine config (``include: foot_mount_case3.yaml``) and adds::

    simulation:
      sample_rate_hz: 5000.0        # plant and controllers in lockstep (default: control rate)
      duration_s: 2.0               # default: the speed profile's length
      speed: {type: constant, speed_hz: 20.0}      # rotor_avc.sim.speed_profile
      unbalance:                    # complex amplitude per excitation of the plant
        static: {magnitude: 1.0e-3, phase_deg: 0.0}     # in the excitation's unit (kg m)
        moment: {magnitude: 2.0e-4, phase_deg: 90.0}    # (kg m^2)
      damping_at: speed             # speed: w_F = max(Omega, floor); whirl: frozen at whirl_rad_s
      initial_state: steady_state   # rest | steady_state (the sampled loop's periodic solution)
      speed_grid_tol: 1.0e-5        # rotor_avc.sim.propagator (accuracy of variable speed)
      test_signal: {actuator: DL, kind: white, rms_n: 200.0, band_hz: [2.0, 400.0], seed: 1}
                                    # optional broadband force for FRFs (rotor_avc.sim.broadband)
      balancer: false               # run the config's `balancer:` (rotor_avc.balancing.loop_block)
      harmonic: false               # run the config's `harmonic:` (rotor_avc.harmonic.config)

The section is declared in :class:`rotor_avc.settings.SimulationSettings`. Checks (each a
:class:`~rotor_avc.errors.ConfigError` naming the field and the fix): a positive
duration; a sample rate above twice the highest rotational frequency and above twice the
highest of the machine's relevant modes (the first ``analysis.worst_case.n_modes``
undamped natural frequencies at standstill, the modes its controllers act on); speeds within
``[0, analysis.frf_speed_hz.stop]``, the range the machine config sets the model up for.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .analysis.active_bearing_ff import feedforward_method, synchronous_generator
from .analysis.design_check import natural_frequencies_hz
from .balancing.loop_block import LoopBalancer
from .block_kinds import BALANCER, FEEDBACK, FEEDFORWARD, HARMONIC, BlockKind
from .balancing.scenario import machine_setup
from .control.block import build_digital_controllers
from .config import scenarios_using
from .errors import ConfigError, ModelError
from .machine import Machine, load_machine, machine_from_config, model_supports, models_supporting
from .settings import SimulationSettings, read_settings
from .sim.broadband import BroadbandForce, broadband_from_config
from .sim.loop import BLOCK_STEPS, run_blocks, run_loop
from .sim.propagator import DampingRule
from .sim.speed_profile import SpeedProfile, profile_from_config
from .sim.stepper import PlantStepper
from .sim.timeseries import TimeSeries

@dataclass(frozen=True, eq=False)
class Scenario:
    machine: Machine
    sample_period_s: float
    duration_s: float
    profile: SpeedProfile
    amplitudes: dict[str, complex]
    damping: DampingRule
    initial_state: str
    grid_tol: float
    use_balancer: bool = False
    #: ``simulation.feedforward`` method (``paper`` or ``exact``: Sci. Rep. 2023's quantified force
    #: played by a 1x generator for the run's unbalance), or None
    feedforward_method: str | None = None
    test_force: BroadbandForce | None = None
    use_harmonic: bool = False
    _tables: dict = field(default_factory=dict, init=False, repr=False)

    @property
    def n_steps(self) -> int:
        return max(1, int(round(self.duration_s / self.sample_period_s)))

    def stepper(self) -> PlantStepper:
        """A stepper at sample 0; every one of this scenario shares one speed grid and its
        matrices (built by the first, extended on demand)."""
        st = PlantStepper(self.machine.plant, self.sample_period_s, self.profile,
                          self.amplitudes, self.damping, self.grid_tol, self.test_force,
                          self._tables.get("table"))
        self._tables["table"] = st.table
        return st

    def controllers(self) -> dict:
        return build_digital_controllers(self.machine, self.sample_period_s)

    def run_config(self) -> dict:
        """The run's configuration as a bag records it (rotor_avc.bag.metadata): the whole
        merged config under ``machine`` plus the sections a reader looks for."""
        data = self.machine.config.data
        sim = data.get("simulation", {})
        return {"machine": data, "source": self.machine.config.source,
                "controllers": data.get("controllers"),
                "discretisation": {**data.get("control", {}),
                                   "sample_rate_hz": 1.0 / self.sample_period_s},
                "balancer": data.get("balancer"), "speed_profile": sim.get("speed"),
                "unbalance": sim.get("unbalance"), "damping": self.damping.describe(),
                "initial_state": self.initial_state,
                "test_signal": None if self.test_force is None else self.test_force.describe()}

    def balancer(self):
        """The balancer block of the run (``simulation.balancer: true``), or None."""
        if not self.use_balancer:
            return None
        return LoopBalancer(machine_setup(self.machine), self.sample_period_s)

    def feedforward(self):
        """The run's synchronous force generator (``simulation.feedforward``), or None."""
        if self.feedforward_method is None:
            return None
        return synchronous_generator(self.machine.plant, self.sample_period_s,
                                     self.amplitudes.get("unbalance", 0j), self.feedforward_method)

    def feedforward_actuators(self) -> list[str]:
        """Actuators the feed-forward drives (all of the plant's), without building its table."""
        if self.feedforward_method is None:
            return []
        return [a.id for a in self.machine.plant.actuators]

    def block_kinds(self) -> dict[BlockKind, tuple[str, ...]]:
        """The answering block kinds of the run (rotor_avc.block_kinds), in their start order,
        each with the ids of its nodes: one per controlled actuator for the feedback
        controllers, ``("",)`` for a kind with one node for the machine."""
        present = {FEEDBACK: tuple(self.machine.controllers),
                   FEEDFORWARD: ("",) if self.feedforward_actuators() else (),
                   HARMONIC: ("",) if self.use_harmonic else (),
                   BALANCER: ("",) if self.use_balancer else ()}
        return {kind: ids for kind, ids in present.items() if ids}

    def harmonic(self):
        """The run's adaptive harmonic controller (``simulation.harmonic: true``), or None."""
        if not self.use_harmonic:
            return None
        from .harmonic.config import harmonic_from_config
        return harmonic_from_config(self.machine, self.sample_period_s,
                                    self.profile.max_speed_rad_s, self.damping.whirl_rad_s)

    def run(self, progress: bool | None = None, balancer=None, harmonic=None,
            controllers=None) -> TimeSeries:
        """The whole run in memory (its size checked first, rotor_avc.sim.loop.run_loop); the
        blocks are built from the config unless given."""
        stepper, controllers, n_steps, options = self._loop(balancer, harmonic, controllers)
        return run_loop(stepper, controllers, n_steps, progress=progress, **options)

    def run_blocks(self, progress: bool | None = None, stop=lambda: False,
                   block_steps: int = BLOCK_STEPS, controllers=None, fast_path: bool = True):
        """The run as consecutive time-series blocks (rotor_avc.sim.loop.run_blocks): memory
        independent of the duration; ``stop()`` True after a block ends the run there."""
        stepper, controllers, n_steps, options = self._loop(controllers=controllers)
        return run_blocks(stepper, controllers, n_steps, progress=progress, stop=stop,
                          block_steps=block_steps, fast_path=fast_path, **options)

    def _loop(self, balancer=None, harmonic=None, controllers=None):
        """``(stepper, controllers, n_steps, options of the loop)``."""
        meta = {"scenario": self.machine.config.source, "config": self.machine.config.data}
        balancer = self.balancer() if balancer is None else balancer
        harmonic = self.harmonic() if harmonic is None else harmonic
        controllers = self.controllers() if controllers is None else controllers
        return (self.stepper(), controllers, self.n_steps,
                {"balancer": balancer, "feedforward": self.feedforward(), "harmonic": harmonic,
                 "initial_state": self.initial_state, "metadata": meta})


def relevant_mode_hz(machine: Machine) -> float:
    """Highest of the first ``n_modes`` undamped natural frequencies at standstill (Hz)."""
    f = natural_frequencies_hz(machine.plant)
    return float(f[:machine.analysis.worst_case.n_modes].max()) if f.size else 0.0


def scenario_from_machine(machine: Machine) -> Scenario:
    """Validate the ``simulation:`` section of a loaded machine config."""
    cfg = machine.config
    sim = cfg.section("simulation")
    # the plant's excitations name the entries of simulation.unbalance (before their values)
    sim.section("unbalance", {}).check_keys(e.name for e in machine.plant.excitations)
    s = read_settings(SimulationSettings, sim)
    control = machine.control
    if s.sample_rate_hz is not None:
        fs = s.sample_rate_hz
        if control.sample_rate_hz is not None and control.sample_rate_hz != fs:
            raise sim.error("sample_rate_hz", f"{fs:g} Hz differs from control.sample_rate_hz "
                            f"{control.sample_rate_hz:g} Hz; plant and controllers "
                            "run in lockstep at one rate", fix="give one rate (or drop one key)")
    else:
        fs = machine.sample_rate_hz
    try:
        profile = profile_from_config(sim.section("speed"))
    except ModelError as exc:
        raise sim.error("speed", str(exc)) from None
    if s.duration_s is not None:
        duration = s.duration_s
    elif profile.length_s is not None:
        duration = profile.length_s
    else:
        raise sim.error("duration_s", "missing, and the speed profile has no length of its own",
                        fix="add `duration_s:` (seconds) to simulation")
    if duration * fs < 1:
        raise sim.error("duration_s", f"{duration:g} s is shorter than one sample at {fs:g} Hz",
                        fix="give a longer duration")
    f_max = profile.max_speed_rad_s / (2 * math.pi)
    frf = machine.analysis.frf_speed_hz
    if frf is not None and f_max > frf.stop * (1 + 1e-12):
        raise sim.error("speed", f"the profile reaches {f_max:g} Hz, beyond the model's range "
                        f"0 .. {frf.stop:g} Hz (analysis.frf_speed_hz.stop)",
                        fix="lower the speeds, or extend analysis.frf_speed_hz.stop if the "
                            "model holds there")
    if fs <= 2 * f_max:
        raise sim.error("sample_rate_hz", f"{fs:g} Hz is not above twice the highest rotational "
                        f"frequency {f_max:g} Hz (the 1x signal would alias)",
                        fix=f"raise the sample rate above {2 * f_max:g} Hz (10x is comfortable)")
    f_mode = relevant_mode_hz(machine)
    if fs <= 2 * f_mode:
        raise sim.error("sample_rate_hz", f"{fs:g} Hz is not above twice the machine's highest "
                        f"relevant mode {f_mode:.1f} Hz (analysis.worst_case.n_modes)",
                        fix=f"raise the sample rate above {2 * f_mode:.0f} Hz")
    damping = DampingRule(s.damping_at, s.whirl_rad_s)
    if s.initial_state == "steady_state" and profile.sample(np.array(0.0))[0] <= 0:
        raise sim.error("initial_state", "a steady state needs the shaft turning at t = 0",
                        fix="start the speed profile above 0 Hz or use `initial_state: rest`")
    if s.balancer and not cfg.has("balancer"):
        raise sim.error("balancer", "true, but the config has no `balancer:` section",
                        fix="include a balancer config (e.g. balancer_foot_mount.yaml)")
    if s.harmonic and not cfg.has("harmonic"):
        raise sim.error("harmonic", "true, but the config has no `harmonic:` section",
                        fix="add a `harmonic:` section (e.g. include harmonic_bearings.yaml)")
    test = (broadband_from_config(s.test_signal, sim.section("test_signal"), machine.plant,
                                  1.0 / fs) if s.test_signal is not None else None)
    return Scenario(
        machine=machine, sample_period_s=1.0 / fs, duration_s=duration, profile=profile,
        amplitudes={name: u.amplitude for name, u in (s.unbalance or {}).items()},
        damping=damping,
        initial_state=s.initial_state, grid_tol=s.speed_grid_tol, use_balancer=s.balancer,
        feedforward_method=_feedforward_method(machine, sim, s), test_force=test,
        use_harmonic=s.harmonic)


def _feedforward_method(machine: Machine, sim, s: SimulationSettings) -> str | None:
    if s.feedforward is None:
        return None
    ff = sim.section("feedforward")
    if not model_supports(machine.config, "feedforward"):
        raise ff.error("type", "the synchronous (1x) force generator is Sci. Rep. 2023's feed-forward "
                       "of the active-bearing rotor",
                       fix="use it with model: " + ", ".join(models_supporting("feedforward")))
    overlap = sorted(set(machine.controllers))
    if overlap:
        raise ff.error("type", f"actuators {overlap} also have feedback controllers",
                       fix="give each actuator either a controller or the feed-forward")
    if s.initial_state != "rest":
        raise sim.error("initial_state", "the feed-forward run starts from rest (the periodic "
                        "solution is computed for feedback controllers only)",
                        fix="use `initial_state: rest` and a duration of several time constants")
    return s.feedforward.method or feedforward_method(machine.config)


def load_scenario(name) -> Scenario:
    """Load a scenario file (a path or a shipped config name); a machine config (no
    ``simulation:``) is refused naming the shipped scenarios that use it."""
    machine = load_machine(name)
    if not machine.config.has("simulation"):
        using = scenarios_using(name)
        raise ConfigError("simulation", "missing: this is a machine config, not a scenario",
                          fix=("run a scenario that uses it: " + ", ".join(using)
                               + ", or " if using else "")
                          + "write one: `include:` this file and add `simulation:` "
                            "(rotor-avc config new)", source=machine.config.source)
    return scenario_from_machine(machine)


def scenario_from_config(data, source: str = "") -> Scenario:
    """A scenario from a merged config mapping already loaded (e.g. the ``machine`` section of a
    bag's configuration); ``source`` labels every error message."""
    return scenario_from_machine(machine_from_config(data, source))
