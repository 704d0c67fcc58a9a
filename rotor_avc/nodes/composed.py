"""A whole graph in one process: recorder, controllers, balancer and plant in one executor.

``python -m rotor_avc.nodes.composed --ros-args -p scenario:=scenario_demo_case3 -p
path:=bags/run.mcap`` builds the nodes of the scenario the way rotor_avc.nodes.graph starts them
as processes, with the same parameters, composed like the nodes of a ROS 2 component container:
the recorder first, taking every message from the nodes' publishers (``source: process``), then
the feedback controllers, the feed-forward node, the harmonic controller and the balancer when
the scenario has them, and
the plant in lockstep with ``wait_for_recorder``. The nodes talk through DDS as in separate
processes (any other node of the domain sees the same traffic); the run just needs no round trip
between processes. Ends when the plant's run ends, with the plant's exit status; SIGINT/SIGTERM
at any time end it cleanly, the bag finished.
"""
from __future__ import annotations

import sys

import rclpy
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions

from ..errors import RotorAvcError
from ..scenario import load_scenario
from . import signals, transport
from .graph_nodes import RECORDER, graph_nodes
from .runtime import close_node, freeze_start_up, make_executor

def build_nodes(scenario_name: str, bag_path: str, nodes: list, executor: str = "events",
                plant_params: dict | None = None) -> list:
    """The scenario's nodes (rotor_avc.nodes.graph_nodes: recorder first, plant last) for one
    executor, appended to ``nodes`` as they are built (so a failure half-way leaves the built
    ones to be closed); the recorder takes the messages from the publishers (``source:
    process``)."""
    from .balancer import Balancer
    from .foot_controller import FootController
    from .harmonic_controller import HarmonicControllerNode
    from .plant_simulator import PlantSimulator
    from .recorder import Recorder
    from .synchronous_controller import SynchronousController
    classes = {"recorder": Recorder, "foot_controller": FootController,
               "synchronous_controller": SynchronousController,
               "harmonic_controller": HarmonicControllerNode, "balancer": Balancer,
               "plant_simulator": PlantSimulator}
    for spec in graph_nodes(load_scenario(scenario_name), bag_path, plant_params):
        values = {**spec.parameters, "executor": executor}
        if spec.name == RECORDER:
            values["source"] = "process"
        nodes.append(classes[spec.executable](spec.name, parameter_overrides=[
            Parameter(k, value=v) for k, v in values.items()]))
    return nodes


#: plant parameters the composed graph takes besides scenario and path (string-valued)
PLANT_PARAMS = ("mode", "realtime_overload")


def _ros_params(args: list[str]) -> dict[str, str]:
    """``-p name:=value`` pairs among ``--ros-args``; scenario and path are required and
    only PLANT_PARAMS are taken besides them."""
    values = {b.split(":=", 1)[0]: b.split(":=", 1)[1] for a, b in zip(args, args[1:])
              if a == "-p" and ":=" in b}
    for name in ("scenario", "path"):
        if name not in values:
            raise RotorAvcError(f"composed: parameter '{name}' is missing -- fix: -p {name}:=...")
    unknown = set(values) - {"scenario", "path", *PLANT_PARAMS}
    if unknown:
        raise RotorAvcError(f"composed: unknown parameter(s) {', '.join(sorted(unknown))} -- "
                            f"fix: use scenario, path or {', '.join(PLANT_PARAMS)}")
    return values


def main(args=None) -> int:
    signals.running()
    argv = list(sys.argv[1:] if args is None else args)
    try:
        values = _ros_params(argv)
        scenario_name, bag = values.pop("scenario"), values.pop("path")
    except RotorAvcError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    transport.use_loopback_profile()          # every UDP socket on 127.0.0.1
    rclpy.init(args=[], signal_handler_options=SignalHandlerOptions.NO)
    nodes, status = [], 0
    try:
        build_nodes(scenario_name, bag, nodes, plant_params=values)
        plant, recorder = nodes[-1], nodes[0]
        executor = make_executor("events")
        for node in nodes:
            executor.add_node(node)
        freeze_start_up()
        try:
            while (rclpy.ok() and not signals.stop_requested() and not plant.exit_requested
                   and not recorder.exit_requested):       # e.g. the bag cannot be written
                executor.spin_once(timeout_sec=0.1)
            recorder.drain(executor)
        finally:
            executor.shutdown()
        status = plant.exit_status or getattr(recorder, "exit_status", 0)
    except RotorAvcError as exc:
        print(f"error: {exc}", file=sys.stderr)
        status = getattr(exc, "exit_status", 2)
    except (signals.Stop, KeyboardInterrupt):
        pass
    finally:
        signals.shutting_down()
        for node in reversed(nodes):              # the plant first, the recorder last
            closed = close_node(node)
            status = status or closed
        if rclpy.ok():
            rclpy.shutdown()
    return status


if __name__ == "__main__":
    raise SystemExit(main())
