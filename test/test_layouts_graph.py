"""The layouts ``rotor-avc layouts`` generates, against a bag the ROS graph recorded of the same
scenario (the recorder node, composed graph): short runs of the Werner 2021 machine with every
kind of block -- case 3's feedback controllers, the balancer, harmonic control from t = 0
(test_layouts.combined_scenario) -- and of the Sci. Rep. 2023 active bearing with its
feed-forward (forces along y and x, from the synchronous controller node). The topics the
generator lists for the scenario are exactly the topics the graph published; every series of
both layouts reads a number from the recorded messages, each array element by an index within
the array the node published and with that array's label (the balancer's estimate and command,
the harmonic controller's forces and status, which only the graph's nodes publish); the
whole-topic panels' topics were published."""
import json

import pytest

from test_layouts import (_foxglove_paths, assert_series_in_bag, combined_scenario,
                          foxglove_series, plotjuggler_series, short)

from rotor_avc.bag import BagReader
from rotor_avc.cli import main
from rotor_avc.reports.layout_panels import graph_topics
from rotor_avc.scenario import load_scenario

pytest.importorskip("rclpy", reason="ROS 2 Jazzy (rclpy) is not installed")


BLOCKS = {"/avc/balancer/estimate", "/avc/balancer/command", "/avc/harmonic/forces",
          "/avc/harmonic/status"}


@pytest.fixture(scope="module", params=["combined", "active_bearing"])
def recorded(request, tmp_path_factory):
    """(scenario config, graph bag, Foxglove layout, PlotJuggler layout)."""
    from rotor_avc.nodes.graph import run_graph
    tmp = tmp_path_factory.mktemp("layouts_graph")
    config = (combined_scenario(tmp) if request.param == "combined"
              else short(tmp, "scenario_active_bearing", 0.05))
    bag = run_graph(str(config), tmp / "graph.mcap", tmp / "logs", layout="composed",
                    timeout_s=600).bag
    assert main(["layouts", str(config), "--out", str(tmp), "--name", "graph"]) == 0
    return config, bag, tmp / "graph.foxglove.json", tmp / "graph.plotjuggler.xml"


def test_the_generator_lists_the_topics_the_graph_published(recorded):
    config, bag, _, _ = recorded
    with BagReader(bag) as reader:
        assert set(reader.topics) == set(graph_topics(load_scenario(config)))


def test_every_layout_series_reads_the_recorded_messages(recorded):
    config, bag, foxglove, plotjuggler = recorded
    plotted = assert_series_in_bag(foxglove_series(foxglove), bag)
    if config.name == "combined.yaml":
        assert BLOCKS <= plotted
    else:
        assert {f"/avc/foot/{a}/actuator_force" for a in ("y1", "x1", "y2", "x2")} <= plotted
    assert assert_series_in_bag(plotjuggler_series(plotjuggler), bag) == plotted
    whole = {p for p in _foxglove_paths(json.loads(foxglove.read_text())) if "." not in p}
    with BagReader(bag) as reader:
        assert whole == {"/avc/plant/observables", "/diagnostics"} <= set(reader.topics)
