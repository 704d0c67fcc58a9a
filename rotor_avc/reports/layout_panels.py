"""What a scenario's ROS graph publishes, as the panels of a viewer layout (``rotor-avc layouts``;
the files: rotor_avc.reports.layout_files).

Topics: the plant's (``rotor/joint_state``, ``plant/observables``, each actuator's acceleration
and the signal its controller feeds back on, ``/clock``, ``/diagnostics``) and those every
answering block of the run records (:meth:`rotor_avc.scenario.Scenario.block_kinds`,
:meth:`rotor_avc.block_kinds.BlockKind.recorded_topics`), names and types from
rotor_avc.bag.topics -- what the graph of the scenario publishes, nothing else.

Panels, each a list of named series (a field of a topic; an element of a labelled array by its
index, named by its label in the array the node publishes: the plant's measurement layout,
rotor_avc.sim.stepper.MeasurementLayout, and rotor_avc.bag.array_labels):

* bearing-housing vibration: the channels ISO 20816-3 rates (``analysis.iso20816.channels``,
  by default the plant's ``bearing*``/``housing*`` outputs: rotor_avc.compare.iso_zones), one
  panel per unit;
* the actuators' forces (N) -- each one's ``actuator_force``; the acceleration at each actuator;
* the shaft speed (rad/s);
* with the balancer: its unbalance estimate and correction command (re, im per excitation);
* with harmonic control: its forces and force phasor magnitudes |U|, its error phasor
  magnitudes |E|, its mode and fall-backs;
* the plant's observables message as a whole and the nodes' diagnostics (Foxglove only).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..bag import topics as T
from ..bag.array_labels import (TIME_LABEL, balancer_labels, harmonic_error_labels,
                                harmonic_force_labels, harmonic_phasor_labels,
                                harmonic_status_labels)
from ..block_kinds import BALANCER, HARMONIC, JOINT_STATE, OBSERVABLES
from ..compare.iso_zones import iso_channels
from ..harmonic.block import MODES
from ..harmonic.config import harmonic_actuators, harmonic_section, harmonic_sensors
from ..sim.stepper import MeasurementLayout

QUANTITY = {0: "displacement", 1: "velocity", 2: "acceleration"}
#: the topics outside the machine's namespace: /clock (the plant) and /diagnostics (every node)
GLOBAL_TOPICS = tuple(t for t in T.TOPIC_TYPES if t.startswith("/"))
DIAGNOSTICS = "/diagnostics"


@dataclass(frozen=True)
class Series:
    """One plotted value: ``field`` (dotted, ``wrench.force.z``) of ``topic``, element ``index``
    of a sequence field, shown as ``label`` (a labelled array's element name)."""

    topic: str
    field: str
    index: int | None = None
    label: str = ""


@dataclass(frozen=True)
class Panel:
    """A plot of ``series``, or (``kind`` ``raw``, ``diagnostics``) a view of one whole topic;
    ``group``: the machine's signals or the blocks' (``machine``, ``blocks``)."""

    key: str
    title: str
    series: tuple[Series, ...] = ()
    kind: str = "plot"
    topic: str = ""
    group: str = "machine"


@dataclass(frozen=True)
class _Published:
    """What rotor_avc.compare.iso_zones reads of a run: its machine and its channels' names."""

    machine: object
    channel_names: tuple[str, ...]


def graph_topics(scenario, namespace: str = T.NAMESPACE) -> dict[str, str]:
    """Every topic the scenario's graph publishes -> its message type."""
    plant = scenario.machine.plant
    feedback = {a: c.feedback for a, c in scenario.machine.controllers.items()}
    names = [T.topic(JOINT_STATE, namespace), T.topic(OBSERVABLES, namespace), *GLOBAL_TOPICS]
    for act in plant.actuators:
        names += [T.actuator_topic(act.id, kind, namespace)
                  for kind in sorted({"acceleration", feedback.get(act.id, "acceleration")})]
    actuators = [a.id for a in plant.actuators]
    for kind, ids in scenario.block_kinds().items():
        for pattern in kind.recorded_topics():
            # a machine-wide node answering per actuator (the feed-forward) drives them all
            for i in (ids if kind.node_per_actuator else actuators) if "{id}" in pattern else ("",):
                names.append(T.topic(pattern.format(id=i), namespace))
    return {name: T.message_type(name, namespace) for name in dict.fromkeys(names)}


def _array(topic: str, labels, wanted=None) -> tuple[Series, ...]:
    """Elements of a labelled array ``time_s, *labels`` (those in ``wanted``), by index."""
    return tuple(Series(topic, "data", i, label)
                 for i, label in enumerate([TIME_LABEL] + list(labels))
                 if i and (wanted is None or label in wanted))


def _housings(scenario, observables: str, layout: MeasurementLayout) -> list[Panel]:
    """The bearing-housing channels ISO 20816-3 rates, one panel per unit."""
    channels = iso_channels(_Published(scenario.machine, tuple(layout.names)))
    panels = []
    for unit in dict.fromkeys(layout.units[c] for c in channels):
        same = [c for c in channels if layout.units[c] == unit]
        quantity = QUANTITY[int(layout.orders[layout.index(same[0])])]
        panels.append(Panel(f"housing_{quantity}", f"bearing-housing {quantity} ({unit})",
                            _array(observables, layout.names, set(same))))
    return panels


def _balancer(scenario, namespace: str) -> list[Panel]:
    plant = scenario.machine.plant
    labels = balancer_labels([e.name for e in plant.excitations])
    units = ", ".join(f"{e.name} {e.unit}" for e in plant.excitations)
    return [Panel(topic.replace("/", "_"), f"balancer: {what} (re, im; {units})",
                  _array(T.topic(topic, namespace), labels), group="blocks")
            for topic, what in ((BALANCER.also_publishes[0], "unbalance estimate"),
                                (BALANCER.answer_topic, "correction command"))]


def _harmonic(scenario, namespace: str, layout: MeasurementLayout) -> list[Panel]:
    machine = scenario.machine
    actuators, sensors = harmonic_actuators(machine), harmonic_sensors(machine)
    harmonics = sorted(int(h) for h in harmonic_section(machine.config).harmonics)
    status = T.topic(HARMONIC.also_publishes[0], namespace)
    labels = harmonic_status_labels(harmonics, sensors, actuators)
    forces = harmonic_force_labels([(a, machine.plant.actuator(a).axis) for a in actuators])
    phasors = set(harmonic_phasor_labels(harmonics, actuators))
    errors = set(harmonic_error_labels(harmonics, sensors))
    units = ", ".join(dict.fromkeys(layout.units[s] for s in sensors))
    return [Panel("harmonic_forces", "harmonic control: forces and |U| (N)",
                  _array(T.topic(HARMONIC.answer_topic, namespace), forces)
                  + _array(status, labels, phasors), group="blocks"),
            Panel("harmonic_errors", f"harmonic control: |E| ({units})",
                  _array(status, labels, errors), group="blocks"),
            Panel("harmonic_mode", "harmonic control: mode ("
                  + ", ".join(f"{i} {mode}" for i, mode in enumerate(MODES)) + "), fall-backs",
                  _array(status, labels, {"mode", "fallbacks"}), group="blocks")]


def layout_panels(scenario, namespace: str = T.NAMESPACE) -> list[Panel]:
    """The panels of the scenario's layout (module docstring), in reading order; every series
    on a topic of :func:`graph_topics`."""
    topics = graph_topics(scenario, namespace)
    plant = scenario.machine.plant
    layout = MeasurementLayout(plant)
    observables = T.topic(OBSERVABLES, namespace)
    forces = [Series(T.actuator_topic(a.id, "actuator_force", namespace),
                     f"wrench.force.{a.axis}", label=a.id) for a in plant.actuators]
    accelerations = [Series(T.actuator_topic(a.id, "acceleration", namespace),
                            f"{T.SIGNAL_FIELDS['acceleration']}.{a.axis}", label=a.id)
                     for a in plant.actuators]
    panels = _housings(scenario, observables, layout)
    panels += [Panel("force", "actuator force (N)",
                     tuple(s for s in forces if s.topic in topics)),
               Panel("acceleration", "acceleration at the actuators (m/s^2)",
                     tuple(accelerations)),
               Panel("speed", "shaft speed (rad/s)",
                     (Series(T.topic(JOINT_STATE, namespace), "velocity", 0, "speed"),))]
    kinds = scenario.block_kinds()
    if BALANCER in kinds:
        panels += _balancer(scenario, namespace)
    if HARMONIC in kinds:
        panels += _harmonic(scenario, namespace, layout)
    panels += [Panel("observables", "plant observables (names: layout.dim[0].label)",
                     kind="raw", topic=observables),
               Panel("diagnostics", "diagnostics", kind="diagnostics", topic=DIAGNOSTICS)]
    return [p for p in panels if p.series or p.kind != "plot"]
