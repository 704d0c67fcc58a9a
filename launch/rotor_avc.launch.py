"""Launch a scenario as the ROS graph: the recorder, one foot controller per controlled foot,
the synchronous (feed-forward) and harmonic controllers and the balancer when the scenario has
them, and the plant in lockstep, waiting for the recorder.

    ros2 launch rotor_avc rotor_avc.launch.py scenario:=scenario_case3_steady \\
        bag:=bags/run.mcap namespace:=avc mode:=lockstep

The nodes and their parameters are those of the launch-free graph
(rotor_avc.nodes.graph_nodes, used by rotor_avc.nodes.graph): every node gets the scenario
config file as its ``scenario`` parameter. ``namespace`` is the nodes' ROS namespace and their
topic namespace (``/<namespace>/foot/...``). When the plant has run the scenario (the recorder
has taken the last sample), the launch shuts down and the recorder finishes the bag.
"""
from datetime import datetime, timezone
from pathlib import Path

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, EmitEvent, OpaqueFunction, RegisterEventHandler
from launch.event_handlers import OnProcessExit
from launch.events import Shutdown
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from rotor_avc.nodes.graph_nodes import graph_nodes
from rotor_avc.scenario import load_scenario

ARGUMENTS = {
    "scenario": ("scenario_case3_steady", "scenario config: a path or a shipped config name"),
    "namespace": ("avc", "ROS namespace and topic namespace of the machine's nodes"),
    "bag": ("", "the .mcap file the recorder writes (must not exist); empty: "
                "<scenario>_<UTC time>.mcap in the current directory"),
    "mode": ("lockstep", "plant_simulator mode: lockstep or realtime"),
}


def _graph(context):
    """The Node actions of the scenario, and the shutdown once the plant is done."""
    value = {name: LaunchConfiguration(name).perform(context) for name in ARGUMENTS}
    scenario = load_scenario(value["scenario"])
    bag = value["bag"] or (f"{Path(scenario.machine.config.source).stem}_"
                           f"{datetime.now(timezone.utc):%Y%m%d-%H%M%S}.mcap")
    nodes = [Node(package="rotor_avc", executable=spec.executable, name=spec.name,
                  namespace=value["namespace"], parameters=[spec.parameters], output="screen")
             for spec in graph_nodes(scenario, bag, {"mode": value["mode"]},
                                     namespace=value["namespace"])]
    done = RegisterEventHandler(OnProcessExit(
        target_action=nodes[-1],
        on_exit=[EmitEvent(event=Shutdown(reason="the plant has run the scenario"))]))
    return nodes + [done]


def generate_launch_description():
    return LaunchDescription(
        [DeclareLaunchArgument(name, default_value=default, description=text)
         for name, (default, text) in ARGUMENTS.items()]
        + [OpaqueFunction(function=_graph)])
