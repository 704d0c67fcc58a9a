"""Every std_msgs/Float64MultiArray the package publishes or records stays within what
PlotJuggler's ROS 2 parser reads (rotor_avc.bag.topics.MAX_ARRAY_ELEMENTS = 100): the labelled
arrays the nodes of every shipped scenario prepare at start-up (built in-process, as the composed
graph builds them), the arrays of the committed bags, and a longer array is refused with the
reason -- by a node at start-up and by the bag writer."""
from pathlib import Path

import numpy as np
import pytest
import yaml

from rotor_avc.bag import BagError, BagReader, topics as T
from rotor_avc.errors import RotorAvcError
from rotor_avc.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = sorted((ROOT / "config").glob("*.yaml"))
SCENARIOS = [p for p in CONFIGS if p.stem.startswith("scenario_")]
#: scenarios whose harmonic controller identifies the loop over a whole run-up (~30 s each)
SLOW = {"scenario_harmonic_case2_runup", "scenario_strategies_runup"}
PARAMS_FILE = "ros_case3"          # ROS parameters for ``ros2 run`` (names a shipped scenario)


def test_limit_is_plotjugglers_default():
    assert T.MAX_ARRAY_ELEMENTS == 100


@pytest.mark.parametrize("path", [pytest.param(p, id=p.stem,
                                               marks=[pytest.mark.sweep] if p.stem in SLOW else [])
                                  for p in SCENARIOS])
def test_every_labelled_array_of_every_scenario_graph(path, tmp_path, full):
    """Builds the scenario's nodes (recorder, controllers, harmonic controller, balancer, plant)
    and checks every labelled array they will publish."""
    if path.stem in SLOW and not full:
        pytest.skip("its harmonic controller identifies the loop over the run-up; --full runs it")
    rclpy = pytest.importorskip("rclpy")
    from rotor_avc.nodes import messages as m
    from rotor_avc.nodes.composed import build_nodes
    from rotor_avc.nodes.runtime import close_node
    scenario = load_scenario(path)
    rclpy.init()
    nodes = []
    try:
        build_nodes(str(path), str(tmp_path / "run.mcap"), nodes)
        arrays = {f"{node.get_name()}.{attr}": value.names for node in nodes
                  for attr, value in vars(node).items() if isinstance(value, m.LabelledBytes)}
    finally:
        for node in reversed(nodes):
            close_node(node)
        rclpy.shutdown()
    expected = {"plant_simulator.observables"}
    if scenario.use_balancer:
        expected |= {"balancer.command", "balancer.estimate"}
    if scenario.use_harmonic:
        expected |= {"harmonic_controller.forces_msg", "harmonic_controller.status_msg"}
    assert set(arrays) == expected
    for name, labels in arrays.items():
        assert labels[0] == "time_s" and 1 < len(labels) <= T.MAX_ARRAY_ELEMENTS, (name, labels)


def test_configs_that_are_no_scenario_publish_nothing():
    """The nodes run scenarios only: every other shipped config (machines, fragments) is refused
    by them with the reason; the ROS parameters file names a shipped scenario."""
    for path in CONFIGS:
        if path.stem == PARAMS_FILE:
            params = yaml.safe_load(path.read_text())["/**"]["ros__parameters"]
            assert (ROOT / "config" / f"{params['scenario']}.yaml") in SCENARIOS
        elif path not in SCENARIOS:
            with pytest.raises(RotorAvcError, match="missing"):
                load_scenario(path)


def test_committed_bags_arrays_fit():
    bags = sorted((ROOT / "bags" / "reference").glob("*.mcap"))
    assert bags
    for bag in bags:
        with BagReader(bag) as reader:
            arrays = [t for t, info in reader.topics.items()
                      if info.msg_type == "std_msgs/msg/Float64MultiArray"]
            assert arrays
            for name in arrays:
                series = reader.series(name)
                assert 1 < len(series.labels) <= T.MAX_ARRAY_ELEMENTS, (bag.name, name)
                assert series["data"].shape[1] == len(series.labels)


def test_longer_arrays_are_refused_with_the_reason():
    labels = ["time_s"] + [f"out_{i}" for i in range(T.MAX_ARRAY_ELEMENTS)]
    t = np.arange(3) * 1e-3
    with pytest.raises(BagError, match=r"plant/observables: 101 elements .*PlotJuggler"):
        T.labelled_array("plant/observables", t, labels, np.zeros((3, len(labels))))
    T.labelled_array("plant/observables", t, labels[:-1], np.zeros((3, len(labels) - 1)))
    pytest.importorskip("rclpy")
    from rotor_avc.nodes import messages as m
    with pytest.raises(RotorAvcError, match=r"101 elements \(time_s \.\.\. out_99\).*fix:"):
        m.LabelledBytes(labels[1:])
    assert len(m.LabelledBytes(labels[2:]).names) == T.MAX_ARRAY_ELEMENTS
