"""A recorded run read back from its bag alone: the scenario rebuilt from the bag's configuration
and every signal a comparison needs on one time base (DESIGN.md section 5).

From the bag (rotor_avc.bag.topics; the namespace is found from ``.../rotor/joint_state``):

* the run's scenario: :func:`rotor_avc.scenario.scenario_from_config` of the configuration's
  ``machine`` section (the whole merged scenario config), so plant, controllers, sample rate,
  speed profile, unbalance, damping rule and test force are the simulator's own; the recorded
  ``damping`` description must match the rebuilt rule;
* ``rotor/joint_state``: time, shaft angle (``position[0]``), speed (``velocity[0]``);
* ``plant/observables``: every labelled measurement (foot signals, plant outputs);
* ``foot/<id>/actuator_force``: the controller's force, channel ``actuator_<id>_f<axis>``;
* ``harmonic/forces`` (a run with the adaptive harmonic controller, rotor_avc.nodes.harmonic_controller):
  its forces, added by the plant to the feedback forces, channel ``harmonic_<id>_f<axis>``;
* ``plant/test_signal``: the broadband test force ``d_k`` when the run had one; a bag without the
  topic (a plant that did not publish it) gets it regenerated from the configuration, which fixes
  it sample by sample (rotor_avc.sim.broadband).

Samples are matched by log time (the sample's sim time); a repeated stamp (a lockstep resend)
counts once, and samples missing from any of the topics are dropped (and counted in ``notes``).
Every problem is a :class:`~rotor_avc.bag.errors.BagError` or
:class:`~rotor_avc.errors.ConfigError` naming it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import reduce
from pathlib import Path

import numpy as np

from ..bag import BagError, BagReader
from ..bag.sequence import require_complete
from ..scenario import Scenario, scenario_from_config


@dataclass
class RecordedRun:
    """A run's configuration and signals (``channels``: name -> values at ``time_s``)."""

    path: Path
    scenario: Scenario
    config: dict
    namespace: str
    time_s: np.ndarray
    angle_rad: np.ndarray
    speed_rad_s: np.ndarray
    channels: dict[str, np.ndarray]
    test_force: np.ndarray | None = None
    test_source: str = ""
    notes: list[str] = field(default_factory=list)

    @property
    def sample_period_s(self) -> float:
        return self.scenario.sample_period_s

    @property
    def machine(self):
        return self.scenario.machine


def _unique(series):
    """Times (ns) and the index of the first message of each distinct time."""
    return np.unique(series.time_ns, return_index=True)


def read_run(path) -> RecordedRun:
    """Read ``path`` (see the module docstring)."""
    path = Path(path)
    with BagReader(path, require_config=True, require_messages=True) as bag:
        config = bag.config
        scenario = scenario_from_config(config["machine"], f"{path} (recorded configuration)")
        recorded = config.get("damping")
        if recorded is not None and recorded != scenario.damping.describe():
            raise BagError(path, f"the recorded damping rule {recorded!r} differs from the one "
                           f"its configuration gives ({scenario.damping.describe()!r})",
                           fix="re-record the run with this version of the package")
        sequence = require_complete(bag, scenario.n_steps)
        joints = [t for t in bag.topics if t.endswith("/rotor/joint_state")]
        if not joints:
            raise BagError(path, "no rotor/joint_state topic: the comparison needs the recorded "
                           "shaft angle and speed", fix="record the plant's rotor/joint_state")
        ns = joints[0][:-len("/rotor/joint_state")]
        plant = scenario.machine.plant
        topics = {"joint": joints[0], "observables": f"{ns}/plant/observables"}
        forces = {f"actuator_{a.id}_f{a.axis}": (f"{ns}/foot/{a.id}/actuator_force",
                                                 f"wrench.force.{a.axis}") for a in plant.actuators}
        for name, (topic, _) in forces.items():
            if topic in bag.topics and bag.topics[topic].count:
                topics[name] = topic
        harmonic_topic = f"{ns}/harmonic/forces"
        if harmonic_topic in bag.topics and bag.topics[harmonic_topic].count:
            topics["harmonic"] = harmonic_topic
        test_topic = f"{ns}/plant/test_signal"
        if scenario.test_force is not None and test_topic in bag.topics:
            topics["test"] = test_topic
        series = {}
        for key, topic in topics.items():          # the shaft angle first
            if topic not in bag.topics:
                raise BagError(path, f"no {topic} topic", fix="record the plant's topics")
            series[key] = bag.series(topic)
    times = {key: _unique(s) for key, s in series.items()}
    common = reduce(np.intersect1d, [t for t, _ in times.values()])
    if common.size < 3:
        raise BagError(path, "fewer than 3 samples are present on every needed topic "
                       f"({', '.join(topics.values())})", fix="record a longer run")
    notes = list(sequence.notes)
    dropped = times["joint"][0].size - common.size
    if dropped:
        notes.append(f"{dropped} samples of rotor/joint_state are missing on another topic and "
                     "were dropped")

    def pick(key, field_name):
        t, first = times[key]
        return series[key][field_name][first[np.searchsorted(t, common)]]

    obs = series["observables"]
    channels = {label: pick("observables", label) for label in obs.labels if label != "time_s"}
    for name, (_, field_name) in forces.items():
        if name in topics:
            channels[name] = pick(name, field_name)
    if "harmonic" in topics:
        channels.update({f"harmonic_{label}": pick("harmonic", label)
                         for label in series["harmonic"].labels if label != "time_s"})
    test, source = None, ""
    if "test" in topics:
        test, source = pick("test", scenario.test_force.channel), f"recorded ({test_topic})"
    elif scenario.test_force is not None:
        k = np.round(common * 1e-9 / scenario.sample_period_s).astype(np.int64)
        test = scenario.test_force.values(0, int(k[-1]) + 1)[k]
        source = "regenerated from the recorded configuration (no plant/test_signal topic)"
    return RecordedRun(path, scenario, config, ns.strip("/"), common * 1e-9,
                       pick("joint", "position[0]"), pick("joint", "velocity[0]"), channels,
                       test, source, notes)
