"""A machine setup from one config file: the plant, its controllers and the analysis settings."""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field

from .closed_loop.loop import ClosedLoop
from .config import load_config
from .section import Section
from .control.spec import ContinuousController, ControllerSettings, controller_settings
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

#: what a model module may declare in ``SUPPORTS``: Sci. Rep. 2023's synchronous feed-forward
#: (``simulation.feedforward``), Werner 2021's one-plane balancer on the machine's bearings
#: (rotor_avc.balancing.scenario.machine_setup), Zhou & Shi 2001's rigid-rotor balancer
#: (``rigid_setup``)
CAPABILITIES = ("feedforward", "plane_balancer", "rigid_balancer")

#: top-level keys every machine config may have; a model module adds its own ``MODEL_KEYS``
COMMON_KEYS = ("model", "name", "description", "controllers", "control", "analysis",
               "simulation", "balancer", "harmonic")


@dataclass(frozen=True, eq=False)
class Machine:
    """A plant with the continuous controllers its config gives, the config itself and its
    validated ``analysis:`` and ``control:`` settings (rotor_avc.settings)."""

    config: Section
    plant: LinearPlant
    controllers: dict[str, ContinuousController]
    #: each actuator's validated ``controllers:`` entry (its digital block's settings too), read
    #: once from ``config`` when not given
    controller_settings: dict[str, ControllerSettings] | None = None
    analysis: AnalysisSettings = field(init=False)
    control: ControlSettings = field(init=False)
    #: the controllers' and every analysis' rate (rotor_avc.settings.sample_rate_hz)
    sample_rate_hz: float = field(init=False)

    def __post_init__(self):
        if self.controller_settings is None:
            object.__setattr__(self, "controller_settings", controller_settings(self.config))
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


def controller_entries(cfg: Section, plant: LinearPlant) -> dict[str, ControllerSettings]:
    """Each actuator's ``controllers:`` entry, validated (rotor_avc.control.spec
    .ControllerSettings); an entry for anything but an actuated foot is refused first."""
    sec = cfg.section("controllers", {})
    ids = [a.id for a in plant.actuators]
    for foot in sec.keys():
        if foot not in ids:
            known = ", ".join(ids) if ids else "none (no foot carries an actuator)"
            raise sec.error(str(foot), "unknown foot id or a foot without an actuator",
                            fix=f"controllers go on actuated feet; this machine's are: {known}")
    return controller_settings(cfg)


def build_controllers(cfg: Section, plant: LinearPlant,
                      entries: dict[str, ControllerSettings] | None = None
                      ) -> dict[str, ContinuousController]:
    """The ``G_c(s)`` of each actuator's ``controllers:`` entry (none for ``type: none``)
    (``entries``: :func:`controller_entries`, if read already)."""
    sec = cfg.section("controllers", {})
    controllers = {}
    for foot, entry in (controller_entries(cfg, plant) if entries is None else entries).items():
        try:
            ctrl = entry.continuous()
            if ctrl is None:
                continue
            if ctrl.structure == "tf" and not ctrl.is_proper:
                raise sec.error(str(foot), "G_c(s) is improper (numerator degree > denominator "
                                "degree) and cannot run as a filter",
                                fix="add a filter pole to the denominator (e.g. a derivative "
                                    "filter)")
            ctrl.law_split()
        except ModelError as exc:
            raise sec.error(str(foot), str(exc)) from None
        controllers[foot] = ctrl
    return controllers


def machine_from_section(cfg: Section) -> Machine:
    """Validate and build a machine from a loaded config (the path every loader shares)."""
    plant = build_plant(cfg)
    entries = controller_entries(cfg, plant)
    return Machine(cfg, plant, build_controllers(cfg, plant, entries), entries)


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
