"""The answer configuration over ROS (rotor_avc.compare.answer_config): a node that a replay
re-drives declares it as a read-only parameter, and ``rotor-avc replay`` reads it from every node
answering a replayed topic before it publishes anything.

* **Node side** -- :func:`declare_answer_config`: the read-only string parameter
  ``answer_config`` (JSON), declared from the node's scenario when it is built; a value given
  on the command line is ignored (it says what the node runs, not what it is told).
* **Replay side** -- :func:`read_answer_configs`: the nodes publishing the answer topics
  (the graph's publisher information), each asked through its parameter service
  ``/<node>/get_parameters`` once that service is ready, all within one bounded time; a node
  without the parameter (an older node, or not one of this package) gets ``text`` None, one
  that does not answer in time says so in ``unread``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rcl_interfaces.srv import GetParameters
from rclpy.node import Node

from ..compare.answer_config import PARAMETER, AnswerConfig
from .runtime import spin_until


def declare_answer_config(node: Node, config: AnswerConfig) -> None:
    """Declare ``config`` as the node's read-only :data:`PARAMETER`."""
    node.declare_parameter(PARAMETER, config.to_json(), ParameterDescriptor(
        name=PARAMETER, type=ParameterType.PARAMETER_STRING, read_only=True,
        description="read-only: what decides this node's answers (JSON: block kind, id, "
                    "fields, steady-state start), compared by `rotor-avc replay` with a bag's "
                    "recorded configuration"), ignore_override=True)


@dataclass(frozen=True)
class NodeAnswerConfig:
    """What a replay learnt of one node answering a replayed topic."""

    name: str                   # fully qualified node name
    answer_topic: str
    text: str | None            # its PARAMETER; None when not declared or not read
    unread: str = ""            # why it was not read (no parameter service, no answer in time)


def answering_nodes(node: Node, topics) -> dict[str, str]:
    """Fully qualified name -> answer topic of every other node that publishes one of
    ``topics``."""
    own = node.get_fully_qualified_name()
    found = {}
    for topic in sorted(topics):
        for info in node.get_publishers_info_by_topic(topic):
            name = info.node_namespace.rstrip("/") + "/" + info.node_name
            if name != own:
                found.setdefault(name, topic)
    return found


def read_answer_configs(node: Node, executor, topics, timeout_s: float
                        ) -> list[NodeAnswerConfig]:
    """:data:`PARAMETER` of every node answering on ``topics`` (see the module docstring), read
    within ``timeout_s``; ``executor`` spins ``node``."""
    nodes = answering_nodes(node, topics)
    clients = {name: node.create_client(GetParameters, f"{name}/get_parameters")
               for name in nodes}
    t_end = time.monotonic() + timeout_s
    try:
        spin_until(executor, lambda: all(c.service_is_ready() for c in clients.values()), t_end)
        futures = {name: c.call_async(GetParameters.Request(names=[PARAMETER]))
                   for name, c in clients.items() if c.service_is_ready()}
        spin_until(executor, lambda: all(f.done() for f in futures.values()), t_end)
        out = []
        for name, topic in nodes.items():
            future = futures.get(name)
            if future is None or not future.done() or future.result() is None:
                why = ("no parameter service" if future is None else "no answer") + \
                      f" within {timeout_s:g} s"
                out.append(NodeAnswerConfig(name, topic, None, why))
                continue
            values = future.result().values    # empty: the parameter is not declared
            text = (values[0].string_value if values
                    and values[0].type == ParameterType.PARAMETER_STRING else None)
            out.append(NodeAnswerConfig(name, topic, text))
        return out
    finally:
        for client in clients.values():
            node.destroy_client(client)
