"""``rotor-avc run``: the launch-free graph as a command -- every sample recorded and counted,
progress with the time left, and each node's parameters listed as the run sets them."""
from __future__ import annotations

import pytest

from ros_helpers import rclpy  # noqa: F401  (skips without ROS)
from test_ros_graph import scenario_file

from rotor_avc.bag import BagReader
from rotor_avc.bag.sequence import check_sequence
from rotor_avc.cli import main
from rotor_avc.nodes.graph_nodes import graph_nodes
from rotor_avc.scenario import load_scenario


@pytest.mark.parametrize("layout", [[], ["--composed"]], ids=["processes", "composed"])
def test_run_records_every_sample_and_prints_the_counts(tmp_path, capfd, layout):
    scenario = scenario_file(tmp_path, "foot_mount_case3", 12.0, duration_s=0.1)
    bag = tmp_path / "run.mcap"
    assert main(["run", scenario, "--bag", str(bag), *layout]) == 0
    out, err = capfd.readouterr()
    with BagReader(bag) as reader:
        seq = check_sequence(reader)
        counts = reader.counts
    assert seq.ok and seq.samples == 500
    assert "500/500 samples" in err and "ETA" in err
    for topic, c in counts.items():
        row = next(line.split() for line in out.splitlines() if line.split()[:1] == [topic])
        assert row[1:] == [str(c["published"]), str(c["recorded"])]
    logs = tmp_path / "run_logs"
    if not layout:                       # one process per node: each says it is ready, and how
        for foot in load_scenario(scenario).machine.controllers:
            text = (logs / f"foot_controller_{foot}.log").read_text()
            assert (f"ready: publishes /avc/foot/{foot}/actuator_force, /diagnostics; "
                    f"subscribes /avc/foot/{foot}/acceleration") in text
        assert "ready: publishes " in (logs / "plant_simulator.log").read_text()


def test_list_params_shows_what_the_run_sets(tmp_path, capsys):
    name = "scenario_harmonic_case3_steady"
    assert main(["run", name, "--list-params", "--bag", str(tmp_path / "b.mcap")]) == 0
    out = capsys.readouterr().out
    specs = graph_nodes(load_scenario(name), tmp_path / "b.mcap")
    heads = [line.split()[0] for line in out.splitlines() if not line.startswith(" ")]
    assert heads == [s.name for s in specs]
    import importlib
    for spec in specs:
        section = out.split(f"{spec.name} (ros2 run rotor_avc {spec.executable}):")[1]
        for p in importlib.import_module(f"rotor_avc.nodes.{spec.executable}").PARAMS:
            line = next(line for line in section.splitlines() if line.split()[:1] == [p.name])
            assert repr(spec.parameters.get(p.name, p.default)) in line
            assert ("(set by the run)" in line) == (p.name in spec.parameters)
    assert not (tmp_path / "b.mcap").exists()
