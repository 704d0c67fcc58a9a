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
* ``harmonic/forces`` (a run with the adaptive harmonic controller,
  rotor_avc.nodes.harmonic_controller): its forces, added by the plant to the feedback forces,
  channel ``harmonic_<id>_f<axis>``;
* ``plant/test_signal``: the broadband test force ``d_k`` when the run had one; a bag without the
  topic (a plant that did not publish it) gets it regenerated from the configuration, which fixes
  it sample by sample (rotor_avc.sim.broadband).

A graph run whose bag says it was not lockstep (its ``rotor_avc_lockstep`` record:
a fault policy stood in for answers, an answer changed, a responder was absent) is not the
sampled loop the comparison rates: :func:`open_run` refuses it with the samples concerned
(rotor_avc.bag.lockstep.NotLockstepError, exit status 6), after the sequence check.

Samples are matched by log time (the sample's sim time); a repeated stamp (a lockstep resend)
counts once, and samples missing from any of the topics are dropped (and counted in ``notes``).
Every problem is a :class:`~rotor_avc.bag.errors.BagError` or
:class:`~rotor_avc.errors.ConfigError` naming it.

**What a comparison consumes** (rotor_avc.compare.comparison): the run's metadata (``path``,
``scenario``, ``config``, ``namespace``, ``notes``, ``channel_names``, ``has_test_force``,
``test_source``), its constant-speed dwells one at a time (:meth:`RecordedRun.dwells`: a
:class:`Dwell` each, at most :data:`MAX_DWELL_SAMPLES` samples, the last of the dwell) and, for a
run without dwells (a run-up), its samples block by block (``blocks()``, which the run-up order
tracking consumes as they come); ``assumptions`` (what a recording of a real machine left to
assumption) and ``tracking`` (a source's own 1x tracking, or None). :class:`RecordedRun` holds
the run in memory (any source can build one: a foreign recording mapped and resampled);
:class:`rotor_avc.compare.bag_source.BagSource` reads a bag in one streaming pass, holding one
dwell or one run-up window at a time.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import reduce
from pathlib import Path

import numpy as np

from ..analysis.order_tracking import dwells
from ..bag import BagError, BagReader
from ..bag.lockstep import require_lockstep
from ..bag.rosbag2 import open_bag
from ..bag.sequence import require_complete
from ..scenario import Scenario, scenario_from_config

#: a dwell longer than this is analysed over its last this-many samples (memory per dwell)
MAX_DWELL_SAMPLES = 2 ** 17


@dataclass
class Dwell:
    """One constant-speed dwell at positive speed: its last samples (``channels``: name ->
    values at ``time_s``), and ``settle_start``, the first of them in the dwell's second half
    (where the 1x analysis starts, after the transient)."""

    time_s: np.ndarray
    angle_rad: np.ndarray
    speed_rad_s: np.ndarray
    channels: dict[str, np.ndarray]
    test_force: np.ndarray | None
    settle_start: int


def tail_dwell(time_s, angle_rad, speed_rad_s, channels, test_force, total: int) -> Dwell:
    """The :class:`Dwell` of a dwell of ``total`` samples from arrays holding at least its last
    ``min(total, MAX_DWELL_SAMPLES)`` samples (ending with its last)."""
    n = min(total, MAX_DWELL_SAMPLES)
    cut = slice(len(time_s) - n, None)
    return Dwell(time_s[cut], angle_rad[cut], speed_rad_s[cut],
                 {k: v[cut] for k, v in channels.items()},
                 None if test_force is None else test_force[cut],
                 max(0, int(0.5 * total) - (total - n)))


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
    #: what a recording of a real machine left to assumption, each value with its source
    #: (rotor_avc.compare.recording_scenario); empty for the package's own bags
    assumptions: dict = field(default_factory=dict)
    #: the run's own 1x order tracking, ``(names, u_ref, runup_revolutions) -> (track, method,
    #: settings)``, where its signals do not share one sample grid (a mapped recording); None:
    #: the comparison tracks the channels on ``time_s``
    tracking: object = None
    #: ``(outputs, freq_hz) -> (F, m)`` complex gain of the resampling on an FRF from the test
    #: force to each output (rotor_avc.analysis.resampling.interpolation_gain, output over
    #: input), where the channels were resampled onto the grid; None: recorded on it
    interpolation: object = None

    @property
    def sample_period_s(self) -> float:
        return self.scenario.sample_period_s

    @property
    def machine(self):
        return self.scenario.machine

    @property
    def channel_names(self) -> list[str]:
        return list(self.channels)

    @property
    def has_test_force(self) -> bool:
        return self.test_force is not None

    def dwells(self):
        """The constant-speed dwells at positive speed, in time order (:class:`Dwell`)."""
        for a, b in dwells(self.speed_rad_s):
            cut = slice(a, b)
            dwell = tail_dwell(self.time_s[cut], self.angle_rad[cut], self.speed_rad_s[cut],
                               {k: v[cut] for k, v in self.channels.items()},
                               None if self.test_force is None else self.test_force[cut], b - a)
            if np.mean(dwell.speed_rad_s) > 0:
                yield dwell

    def blocks(self):
        """The run as blocks ``(time_s, angle_rad, speed_rad_s, channels, test_force)`` in time
        order (here: one block; a streamed source yields many)."""
        yield self.time_s, self.angle_rad, self.speed_rad_s, self.channels, self.test_force


def _unique(series):
    """Times (ns) and the index of the first message of each distinct time."""
    return np.unique(series.time_ns, return_index=True)


@dataclass
class OpenedRun:
    """What a bag says about its run before its signals are read."""

    path: Path
    config: dict
    scenario: Scenario
    notes: list[str]
    namespace: str
    topics: dict[str, str]                     # key -> topic: joint, observables, forces ...
    forces: dict[str, tuple[str, str]]         # channel -> (topic, field)


def open_run(bag: BagReader, path: Path) -> OpenedRun:
    """The scenario, the sequence check and the topics of a bag (see the module docstring)."""
    config = bag.config
    scenario = scenario_from_config(config["machine"], f"{path} (recorded configuration)")
    recorded = config.get("damping")
    if recorded is not None and recorded != scenario.damping.describe():
        raise BagError(path, f"the recorded damping rule {recorded!r} differs from the one "
                       f"its configuration gives ({scenario.damping.describe()!r})",
                       fix="re-record the run with this version of the package")
    sequence = require_complete(bag, scenario.n_steps)
    require_lockstep(bag.metadata, path)
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
    bag.codec(topics["joint"])                  # the shaft angle's schema is checked first
    for topic in topics.values():
        if topic not in bag.topics:
            raise BagError(path, f"no {topic} topic", fix="record the plant's topics")
    return OpenedRun(path, config, scenario, list(sequence.notes), ns, topics, forces)


def matched(opened: OpenedRun, series: dict):
    """The samples present on every topic of ``series`` (key -> TopicSeries): ``(time_ns,
    pick, dropped)`` with ``pick(key, field)`` that field at those times and ``dropped`` the
    joint-state samples missing elsewhere."""
    times = {key: _unique(s) for key, s in series.items()}
    common = reduce(np.intersect1d, [t for t, _ in times.values()])

    def pick(key, field_name):
        t, first = times[key]
        return series[key][field_name][first[np.searchsorted(t, common)]]
    return common, pick, times["joint"][0].size - common.size


def signals(opened: OpenedRun, series: dict, common, pick):
    """``(channels, test_force)`` of the matched samples."""
    obs = series["observables"]
    channels = {label: pick("observables", label) for label in obs.labels if label != "time_s"}
    for name, (_, field_name) in opened.forces.items():
        if name in opened.topics:
            channels[name] = pick(name, field_name)
    if "harmonic" in opened.topics:
        channels.update({f"harmonic_{label}": pick("harmonic", label)
                         for label in series["harmonic"].labels if label != "time_s"})
    test = opened.scenario.test_force
    if "test" in opened.topics:
        return channels, pick("test", test.channel)
    if test is not None:
        k = np.round(common * 1e-9 / opened.scenario.sample_period_s).astype(np.int64)
        return channels, (test.values(int(k[0]), int(k[-1] - k[0]) + 1)[k - k[0]]
                          if k.size else np.zeros(0))
    return channels, None


def test_source(opened: OpenedRun) -> str:
    if "test" in opened.topics:
        return f"recorded ({opened.topics['test']})"
    if opened.scenario.test_force is not None:
        return "regenerated from the recorded configuration (no plant/test_signal topic)"
    return ""


def dropped_note(dropped: int) -> str:
    return (f"{dropped} samples of rotor/joint_state are missing on another topic and were "
            "dropped")


def too_short(opened: OpenedRun) -> BagError:
    return BagError(opened.path, "fewer than 3 samples are present on every needed topic "
                    f"({', '.join(opened.topics.values())})", fix="record a longer run")


def read_run(path, integrity: bool = True) -> RecordedRun:
    """Read ``path``, a .mcap file or a rosbag2 directory, into memory (see the module
    docstring); ``integrity``: the file first passes the bag integrity pass."""
    path = Path(path)
    with open_bag(path, require_config=True, require_messages=True, integrity=integrity) as bag:
        opened = open_run(bag, path)
        series = {key: bag.series(topic) for key, topic in opened.topics.items()}
    common, pick, dropped = matched(opened, series)
    if common.size < 3:
        raise too_short(opened)
    notes = opened.notes + ([dropped_note(dropped)] if dropped else [])
    channels, test = signals(opened, series, common, pick)
    return RecordedRun(path, opened.scenario, opened.config, opened.namespace.strip("/"),
                       common * 1e-9, pick("joint", "position[0]"), pick("joint", "velocity[0]"),
                       channels, test, test_source(opened), notes)
