"""The nodes of a graph run and their parameters, in one place for both ways to start them:
the launch-free runner (rotor_avc.nodes.graph, ``python -m ... --ros-args -p``) and the launch
file (``launch/rotor_avc.launch.py``, ``ros2 launch rotor_avc rotor_avc.launch.py``).

A run of a scenario has the recorder first, then the nodes of the answering block kinds the
scenario has (rotor_avc.block_kinds, in their declared order: one ``foot_controller`` per
controlled actuator, the ``synchronous_controller`` for a feed-forward scenario, the
``harmonic_controller`` for ``simulation.harmonic``, the ``balancer`` when the scenario has one),
and the ``plant_simulator`` last, in lockstep with ``wait_for_recorder`` and told which kinds to
wait for. Every node gets the scenario config file itself as
its ``scenario`` parameter (the one parameter file of the run). Free of rclpy: the launch file
and its test read it without a ROS installation.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

#: the node every lockstep plant waits for before sample 0
RECORDER = "recorder"


@dataclass(frozen=True)
class NodeSpec:
    """One node of the run: its name, its executable (a console script of the package, the
    module ``rotor_avc.nodes.<executable>``) and its parameters."""

    name: str
    executable: str
    parameters: dict

    def ros_args(self) -> list[str]:
        """``--ros-args -r __node:=<name> -p key:=value ...`` (booleans as true/false)."""
        args = ["--ros-args", "-r", f"__node:={self.name}"]
        for key, value in self.parameters.items():
            text = str(value).lower() if isinstance(value, bool) else str(value)
            args += ["-p", f"{key}:={text}"]
        return args


def graph_nodes(scenario, bag: str | Path, plant_params: dict | None = None,
                namespace: str | None = None) -> list[NodeSpec]:
    """The nodes of a run of ``scenario`` recording ``bag``, recorder first and plant last;
    ``plant_params``: more plant_simulator parameters (e.g. ``{"mode": "realtime"}``);
    ``namespace``: the topic namespace of every node (default: the nodes' own, ``avc``)."""
    common = {"scenario": str(scenario.machine.config.source)}
    if namespace:
        common["namespace"] = namespace
    specs = [NodeSpec(RECORDER, "recorder", {**common, "path": str(bag)})]
    plant = {**common, "wait_for_recorder": RECORDER}
    for kind, ids in scenario.block_kinds().items():
        for actuator in ids:
            if kind.node_per_actuator:
                specs.append(NodeSpec(f"{kind.node}_{actuator}", kind.node,
                                      {**common, kind.id_param: actuator}))
            else:
                specs.append(NodeSpec(kind.node, kind.node, dict(common)))
        if kind.plant_flag:
            plant[kind.plant_flag] = True
    specs.append(NodeSpec("plant_simulator", "plant_simulator", {**plant, **(plant_params or {})}))
    return specs
