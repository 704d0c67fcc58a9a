"""What decides a replayed block's answers, read from a configuration, and a bag's against a
node's (free of ROS: ``rotor-avc replay`` asks the node, rotor_avc.nodes.replay_config).

A block that answers the plant at every sample (rotor_avc.block_kinds: a foot controller, the
balancer) gives the recorded answers again for the recorded inputs only when it runs the recorded
configuration. What decides them, as dotted configuration paths with their values (defaults
filled, rotor_avc.config_documents.resolve):

* ``sample_rate_hz`` -- the run's one rate (DESIGN.md section 6), ``control.method`` and
  ``control.prewarp_hz`` -- the discretisation of ``G_c(s)`` (Werner 2021 eq. 6);
* a foot controller (kind ``feedback``): its ``controllers.<id>`` entry -- ``G_c`` as type and
  gains (or ``tf``'s num/den), the feedback quantity (eq. 7), the force and rate limits, the
  anti-windup and the plausible measurement range as the block takes them
  (rotor_avc.control.block) -- and ``simulation.initial_state``. A filter started on the loop's
  periodic solution (``steady_state``, rotor_avc.sim.steady_state) depends on the whole loop at
  ``t = 0``: the shaft speed and acceleration then (``initial_state.speed_hz``,
  ``initial_state.acceleration_hz_per_s``), the unbalance, the damping rule, the machine's model
  keys and every controller; those are :attr:`AnswerConfig.steady_start`, compared only when
  both sides start so;
* the balancer: the ``balancer:`` section, the machine's model keys and every controller (its
  influence tables come from the closed loop, rotor_avc.balancing.scenario).

Numbers are equal within a relative tolerance (:data:`REL_TOL`), lists element by element, the
rest exactly. A node publishes its :class:`AnswerConfig` as the read-only string parameter
:data:`PARAMETER` (JSON), so ``ros2 param get /foot_controller answer_config`` shows it too.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..bag.topics import NAMESPACE
from ..block_kinds import BALANCER, FEEDBACK, KINDS
from ..config import find_config
from ..config_documents import resolve
from ..errors import RotorAvcError
from ..machine import COMMON_KEYS
from ..scenario import Scenario, load_scenario, scenario_from_config

#: the read-only node parameter holding :meth:`AnswerConfig.to_json`
PARAMETER = "answer_config"
#: numbers closer than this (relative) are equal (a rate as 1 / (1 / f), a value through YAML)
REL_TOL = 1e-9
#: the keys of a steady-state start besides the model keys and the controllers
_STEADY_KEYS = ("simulation.damping_at", "simulation.whirl_rad_s", "simulation.speed_grid_tol",
                "analysis.damping_floor_hz")
_CONTROL_KEYS = ("control.method", "control.prewarp_hz")
#: a value one side does not have
MISSING = object()


@dataclass(frozen=True)
class AnswerConfig:
    """What decides the answers of one block (see the module docstring): its kind (a
    rotor_avc.block_kinds name), its actuator id (``""`` for one block per machine), the fields
    always compared and those of a steady-state start."""

    kind: str
    block_id: str
    fields: dict[str, Any]
    steady_start: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> str:
        return json.dumps({"kind": self.kind, "id": self.block_id, "fields": self.fields,
                           "steady_start": self.steady_start}, separators=(",", ":"))

    @classmethod
    def from_json(cls, text: str) -> "AnswerConfig":
        """The inverse of :meth:`to_json` (ValueError naming what is wrong)."""
        try:
            data = json.loads(text)
        except ValueError as exc:
            raise ValueError(f"not JSON ({exc})") from None
        if not (isinstance(data, dict) and isinstance(data.get("kind"), str)
                and isinstance(data.get("id"), str) and isinstance(data.get("fields"), dict)
                and isinstance(data.get("steady_start", {}), dict)):
            raise ValueError("not a mapping with kind, id, fields and steady_start")
        return cls(data["kind"], data["id"], data["fields"], data.get("steady_start", {}))


def answer_config(scenario: Scenario, kind: str, block_id: str = "") -> AnswerConfig:
    """What decides the answers of the ``kind`` block ``block_id`` of ``scenario`` (a kind a
    replay re-drives: ``feedback`` or ``balancer``; ValueError for another)."""
    if kind not in (FEEDBACK.name, BALANCER.name):
        raise ValueError(f"no answer configuration of block kind {kind!r}")
    entries = {".".join(e.path): e.value for e in resolve(scenario.machine.config)}
    top = lambda path: path.split(".", 1)[0]                             # noqa: E731
    machine = {p: v for p, v in entries.items() if top(p) == "model" or top(p) not in COMMON_KEYS}
    controllers = {p: v for p, v in entries.items() if top(p) == "controllers"}
    fields = {"sample_rate_hz": 1.0 / scenario.sample_period_s,
              **{p: entries[p] for p in _CONTROL_KEYS if p in entries}}
    if kind == BALANCER.name:
        fields.update({p: v for p, v in entries.items() if top(p) == "balancer"})
        return AnswerConfig(kind, block_id, {**fields, **machine, **controllers})
    own = f"controllers.{block_id}."
    fields.update({p: v for p, v in controllers.items() if p.startswith(own)})
    block = scenario.controllers().get(block_id)
    if block is not None:                              # as the block takes them (defaults)
        fields[own + "anti_windup"] = block.anti_windup
        fields[own + "measurement_limit"] = block.measurement_limit
    fields["simulation.initial_state"] = scenario.initial_state
    steady = {}
    if scenario.initial_state == "steady_state":
        speed, accel, _ = (float(v) for v in scenario.profile.sample(np.array(0.0)))
        steady = {"initial_state.speed_hz": speed / (2 * math.pi),
                  "initial_state.acceleration_hz_per_s": accel / (2 * math.pi),
                  **{p: v for p, v in entries.items() if p.startswith("simulation.unbalance.")
                     or p in _STEADY_KEYS},
                  **machine, **{p: v for p, v in controllers.items() if not p.startswith(own)}}
    return AnswerConfig(kind, block_id, fields, steady)


@dataclass(frozen=True)
class Difference:
    """One field the bag and the node give differently (:data:`MISSING` where one has none)."""

    field: str
    bag: Any
    node: Any
    #: what the node's side is when the node gave no value (``node`` is MISSING)
    node_missing: str = "(not given)"

    def line(self) -> str:
        node = self.node_missing if self.node is MISSING else value_text(self.node)
        return f"{self.field}: bag {value_text(self.bag)}, node {node}"


def value_text(value: Any) -> str:
    """A value as the configuration reads it (numbers to 10 digits, ``none``, lists)."""
    if value is MISSING:
        return "(not given)"
    if value is None:
        return "none"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:.10g}"
    if isinstance(value, list):
        return "[" + ", ".join(value_text(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {value_text(v)}" for k, v in value.items()) + "}"
    return str(value)


def same_value(a: Any, b: Any, rel_tol: float = REL_TOL) -> bool:
    """Equal numbers within ``rel_tol`` (booleans exactly), lists element by element."""
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(a, b, rel_tol=rel_tol, abs_tol=0.0)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same_value(x, y, rel_tol) for x, y in zip(a, b))
    return a == b


def _field_differences(bag: dict, node: dict, rel_tol: float) -> list[Difference]:
    keys = list(bag) + [k for k in node if k not in bag]
    return [Difference(k, bag.get(k, MISSING), node.get(k, MISSING)) for k in keys
            if not same_value(bag.get(k, MISSING), node.get(k, MISSING), rel_tol)]


def differences(bag: AnswerConfig, node: AnswerConfig, rel_tol: float = REL_TOL
                ) -> list[Difference]:
    """Every field the two give differently: the block, the fields, and the steady-state start's
    fields when both start in the steady state (else ``simulation.initial_state`` differs)."""
    out = [Difference(name, a, b) for name, a, b in (("block kind", bag.kind, node.kind),
                                                      ("block id", bag.block_id, node.block_id))
           if a != b]
    out += _field_differences(bag.fields, node.fields, rel_tol)
    if bag.steady_start and node.steady_start:
        out += _field_differences(bag.steady_start, node.steady_start, rel_tol)
    return out


def answering_block(topic: str):
    """``(kind, actuator id, namespace)`` of the block a replay re-drives that answers on
    ``topic`` (a replayable kind of rotor_avc.block_kinds, its answer topic under any
    namespace), or None."""
    segments = topic.split("/")
    for kind in KINDS:
        parts = kind.answer_topic.split("/")
        tail = segments[-len(parts):]
        if (kind.replayable and len(segments) > len(parts)
                and all(p in (t, "{id}") for p, t in zip(parts, tail))):
            block_id = tail[parts.index("{id}")] if "{id}" in parts else ""
            return kind, block_id, "/".join(segments[:-len(parts)]).lstrip("/")
    return None


@dataclass(frozen=True)
class NodeCheck:
    """One answering node against the bag: how its configuration differs, and the command that
    starts it with the bag's (empty when none differs)."""

    node: str                       # fully qualified node name
    answer_topic: str
    differences: list[Difference]
    command: str


class BagAnswers:
    """The answer configurations a bag's recorded configuration gives (its scenario built once,
    when a node is first checked)."""

    def __init__(self, config: dict, path):
        self.config, self.path = config, path
        self._scenario: Scenario | RotorAvcError | None = None
        self._answers: dict[tuple[str, str], AnswerConfig] = {}

    def answers(self, kind: str, block_id: str) -> AnswerConfig:
        """The bag's :class:`AnswerConfig` of a block (RotorAvcError when this version cannot
        read the recorded configuration)."""
        if self._scenario is None:
            try:
                self._scenario = scenario_from_config(self.config["machine"],
                                                      f"{self.path} (recorded configuration)")
            except RotorAvcError as exc:
                self._scenario = exc
        if isinstance(self._scenario, RotorAvcError):
            raise self._scenario
        if (kind, block_id) not in self._answers:
            self._answers[kind, block_id] = answer_config(self._scenario, kind, block_id)
        return self._answers[kind, block_id]

    def check(self, node_name: str, answer_topic: str, node_text: str | None,
              unread: str = "", rel_tol: float = REL_TOL) -> NodeCheck:
        """``node_text``: the node's :data:`PARAMETER`, None when it does not declare it (a node
        of an older version, or not one of this package) or when it could not be read (why:
        ``unread``); that, a value that cannot be parsed and a recorded configuration this
        version cannot read are one difference each, saying so."""
        block = answering_block(answer_topic)
        try:
            node = None if node_text is None else AnswerConfig.from_json(node_text)
            problem = (f"not read: {unread}" if unread else
                       "not declared: a node of an older version, or not one of rotor_avc's; "
                       "its configuration cannot be compared")
        except ValueError as exc:
            node, problem = None, f"unreadable: {exc}"
        if block is None and node is not None:
            block = next((k for k in KINDS if k.name == node.kind), None), node.block_id, None
        kind, block_id, namespace = block or (None, "", None)
        found = ([Difference(PARAMETER, "(the recorded configuration)", MISSING, f"({problem})")]
                 if node is None else self._differences(kind, block_id, node, rel_tol))
        command = (start_command(kind, block_id, node_name, self.argument(kind, block_id),
                                 namespace) if found else "")
        return NodeCheck(node_name, answer_topic, found, command)

    def _differences(self, kind, block_id: str, node: AnswerConfig,
                     rel_tol: float) -> list[Difference]:
        if kind is None or not kind.replayable:
            return [Difference("block kind", "a block replay re-drives ("
                               + ", ".join(k.name for k in KINDS if k.replayable) + ")",
                               node.kind)]
        try:
            bag = self.answers(kind.name, block_id)
        except RotorAvcError as exc:
            return [Difference("recorded configuration", f"(cannot be read here: {exc})",
                               MISSING, "(not compared)")]
        return differences(bag, node, rel_tol)

    def argument(self, kind, block_id: str) -> str | None:
        """A ``scenario`` parameter that gives the bag's configuration of the block: the
        shipped config of the recorded source's name, else the recorded source file as named,
        when it (still) gives the same; None when neither does."""
        source = str(self.config.get("source") or "")
        if kind is None or not kind.replayable or not source:
            return None
        try:
            bag = self.answers(kind.name, block_id)
        except RotorAvcError:
            return None
        for candidate in (Path(source).stem, source):
            try:
                find_config(candidate)
                scenario = load_scenario(candidate)
            except RotorAvcError:
                continue
            if not differences(bag, answer_config(scenario, kind.name, block_id)):
                return candidate
        return None


def start_command(kind, block_id: str, node_name: str, scenario: str | None,
                  namespace: str | None = None) -> str:
    """The command that starts a ``kind`` node (its console script, rotor_avc.block_kinds) with
    ``scenario``, under the node's name, for the actuator and the topic namespace it answers
    (None: the node's default)."""
    name = node_name.rsplit("/", 1)[-1]
    if kind is None:
        return f"the node {name} with the bag's configuration"
    args = [kind.node, "--ros-args"]
    if name != kind.node:
        args += ["-r", f"__node:={name}"]
    args += ["-p", "scenario:=" + (scenario or "<a scenario file with the bag's configuration>")]
    if kind.node_per_actuator:
        args += ["-p", f"{kind.id_param}:={block_id}"]
    if namespace is not None and namespace != NAMESPACE:
        args += ["-p", f"namespace:={namespace or repr('')}"]
    return " ".join(args)
