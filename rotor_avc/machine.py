"""A machine setup from one config file: the plant, its controllers and the analysis settings."""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field

from .closed_loop.loop import ClosedLoop
from .config import Section, load_config
from .control.spec import ContinuousController, controller_from_config
from .errors import ConfigError, ModelError
from .models.plant import LinearPlant
from .settings import (AnalysisSettings, ControlSettings, analysis_settings, control_settings,
                       sample_rate_hz)

#: ``model:`` key -> module with ``build(cfg) -> LinearPlant``
MODELS = {
    "foot_mount_3d": "rotor_avc.model_config.foot_mount_3d",
    "roller_bearing_rotor": "rotor_avc.model_config.roller_bearing_rotor",
    "active_bearing": "rotor_avc.model_config.active_bearing",
    "rigid_rotor": "rotor_avc.model_config.rigid_rotor",
    "sleeve_bearing_motor": "rotor_avc.model_config.sleeve_bearing_motor",
}

#: what a model module may declare in ``SUPPORTS``: seed 002's synchronous feed-forward
#: (``simulation.feedforward``), seed 000's one-plane balancer on the machine's bearings
#: (rotor_avc.balancing.scenario.machine_setup), seed 004's rigid-rotor balancer
#: (``rigid_setup``)
CAPABILITIES = ("feedforward", "plane_balancer", "rigid_balancer")

#: top-level keys every machine config may have; a model module adds its own ``MODEL_KEYS``
COMMON_KEYS = ("model", "name", "description", "controllers", "control", "analysis",
               "simulation", "balancer", "harmonic")

#: per-foot keys the digital controller reads (rotor_avc.control); allowed next to G_c(s)
RUNTIME_CONTROLLER_KEYS = ("force_limit_n", "rate_limit_n_per_s", "anti_windup",
                           "back_calculation_gain", "delay_samples", "measurement_limit")


@dataclass(frozen=True, eq=False)
class Machine:
    """A plant with the continuous controllers its config gives, the config itself and its
    validated ``analysis:`` and ``control:`` settings (rotor_avc.settings)."""

    config: Section
    plant: LinearPlant
    controllers: dict[str, ContinuousController]
    analysis: AnalysisSettings = field(init=False)
    control: ControlSettings = field(init=False)
    #: the controllers' and every analysis' rate (rotor_avc.settings.sample_rate_hz)
    sample_rate_hz: float = field(init=False)

    def __post_init__(self):
        object.__setattr__(self, "analysis", analysis_settings(self.config))
        object.__setattr__(self, "control", control_settings(self.config))
        object.__setattr__(self, "sample_rate_hz", sample_rate_hz(self.config))

    @property
    def loop(self) -> ClosedLoop:
        return ClosedLoop(self.plant, self.controllers)



def model_supports(cfg: Section, capability: str) -> bool:
    """Whether the config's model declares ``capability`` (one of :data:`CAPABILITIES`)."""
    if capability not in CAPABILITIES:
        raise ValueError(f"unknown capability {capability!r}; use one of {CAPABILITIES}")
    module = importlib.import_module(MODELS[cfg.choice("model", MODELS)])
    return capability in getattr(module, "SUPPORTS", ())


def models_supporting(capability: str) -> list[str]:
    """The ``model:`` names whose modules declare ``capability``."""
    return [name for name, path in MODELS.items()
            if capability in getattr(importlib.import_module(path), "SUPPORTS", ())]


def build_plant(cfg: Section) -> LinearPlant:
    model = cfg.choice("model", MODELS)
    module = importlib.import_module(MODELS[model])
    cfg.check_keys(COMMON_KEYS + module.MODEL_KEYS)
    try:
        return module.build(cfg)
    except ModelError as exc:
        raise ConfigError("(model)", str(exc), source=cfg.source) from None


def build_controllers(cfg: Section, plant: LinearPlant) -> dict[str, ContinuousController]:
    sec = cfg.section("controllers", {})
    ids = [a.id for a in plant.actuators]
    controllers = {}
    for foot in sec.keys():
        if foot not in ids:
            known = ", ".join(ids) if ids else "none (no foot carries an actuator)"
            raise sec.error(str(foot), "unknown foot id or a foot without an actuator",
                            fix=f"controllers go on actuated feet; this machine's are: {known}")
        ctrl = controller_from_config(sec.section(foot), RUNTIME_CONTROLLER_KEYS)
        if ctrl is None:
            continue
        if ctrl.structure == "tf" and not ctrl.is_proper:
            raise sec.error(str(foot), "G_c(s) is improper (numerator degree > denominator "
                            "degree) and cannot run as a filter",
                            fix="add a filter pole to the denominator (e.g. a derivative filter)")
        try:
            ctrl.law_split()
        except ModelError as exc:
            raise sec.error(str(foot), str(exc)) from None
        controllers[foot] = ctrl
    return controllers


def machine_from_section(cfg: Section) -> Machine:
    """Validate and build a machine from a loaded config (the path every loader shares)."""
    plant = build_plant(cfg)
    return Machine(cfg, plant, build_controllers(cfg, plant))


def load_machine(name) -> Machine:
    """Load, validate and build a machine config (a path or a shipped config name)."""
    return machine_from_section(load_config(name))


def machine_from_config(data, source: str = "") -> Machine:
    """Build a machine from a merged config mapping that is already loaded, e.g. the ``machine``
    section a bag records (rotor_avc.bag.metadata); ``source`` labels every error message
    (``"run.mcap (recorded configuration)"``)."""
    if not isinstance(data, dict):
        raise ConfigError("(top level)", f"must be a mapping of keys to values (got "
                          f"{type(data).__name__})", fix="give the merged machine config",
                          source=source)
    return machine_from_section(Section(data, "", source))
