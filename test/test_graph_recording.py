"""The ROS graph records every sample, also on a busy machine: the graph launcher
(rotor_avc.nodes.graph) in both layouts, with two CPU-bound competitors, records per topic as
many messages as were published, and the bag's messages equal those of the in-process loop's bag
of the same scenario, every block on its per-sample path as in the graph (`rotor-avc simulate
--per-sample --out x.mcap`), byte for byte; a recorder that stops
mid-run ends the lockstep run with exit status 1 and a message saying so; the demo's scenarios
and config/ros_case3.yaml run through the launcher."""
import signal
import time
from pathlib import Path

import pytest
import yaml

from ros_helpers import node_process, rclpy, stop  # noqa: F401
from test_ros_graph import scenario_file

from rotor_avc.bag import BagReader
from rotor_avc.bag.check import check_bag
from rotor_avc.bag.sequence import SAMPLED, check_sequence
from rotor_avc.cli import main
from rotor_avc.config import find_config
from rotor_avc.nodes.graph import run_graph
from rotor_avc.scenario import load_scenario

pytestmark = pytest.mark.ros
ROOT = Path(__file__).resolve().parents[1]


def short_scenario(tmp_path: Path, base: str, **simulation) -> str:
    """A shipped scenario with some of its simulation settings replaced (a shorter run)."""
    path = tmp_path / f"{base}_short.yaml"
    path.write_text(yaml.safe_dump({"include": str(find_config(base)),
                                    "simulation": simulation}))
    return str(path)


def messages_by_topic(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    """Every message of the bag but /diagnostics: topic -> [(log time, CDR bytes)]. A sample the
    lockstep plant published again (its resend of an unanswered sample, on a busy machine) and
    the answers to it must repeat the first message byte for byte; they are counted once."""
    out: dict[str, list] = {}
    first: dict[tuple[str, int], bytes] = {}
    with BagReader(path) as r:
        for msg in r.raw_messages():
            if msg.topic == "/diagnostics":
                continue
            key = (msg.topic, msg.time_ns)
            if key in first:
                assert first[key] == msg.data, f"{msg.topic} at {msg.time_ns} ns: a repeat differs"
                continue
            first[key] = msg.data
            out.setdefault(msg.topic, []).append((msg.time_ns, msg.data))
    return out


def assert_recorded_like_in_process(run, scenario: str, tmp_path: Path):
    assert run.counts, "the bag carries no message counts"
    assert run.lost() == {}
    for topic, c in run.counts.items():
        assert c["published"] == c["recorded"] and c["lost"] == 0, (topic, c)
    sim = tmp_path / "in_process.mcap"
    assert main(["simulate", scenario, "--out", str(sim), "--per-sample"]) == 0
    graph, loop = messages_by_topic(run.bag), messages_by_topic(sim)
    assert sorted(graph) == sorted(loop)
    for topic in loop:
        assert graph[topic] == loop[topic], f"{topic} differs from the in-process loop's bag"
    with BagReader(run.bag) as r:
        assert check_sequence(r).ok
    for bag in (run.bag, sim):                     # ros2 bag / Foxglove pitfalls, integrity
        assert [str(line) for line in check_bag(bag) if not line.ok] == []


@pytest.mark.parametrize("base, layout", [("scenario_demo_case2", "processes"),
                                          ("scenario_demo_case3", "processes"),
                                          ("scenario_demo_case3", "composed")])
def test_graph_records_every_sample_under_contention(tmp_path, competitors, base, layout):
    """(a) the open loop (plant + recorder: the plant outruns any recorder) and (b) the closed
    loop (plant, three controllers, recorder), the demo's stepped run-up shortened."""
    sc = short_scenario(tmp_path, base, speed={"type": "stepped", "speeds_hz": [9.39, 24.84],
                                               "dwell_s": 0.4, "transition_s": 0.1})
    run = run_graph(sc, tmp_path / "run.mcap", tmp_path / "logs", layout=layout, timeout_s=600)
    assert run.steps == load_scenario(sc).n_steps > 4000
    assert_recorded_like_in_process(run, sc, tmp_path)


@pytest.mark.parametrize("layout", ["processes", "composed"])
def test_graph_records_the_harmonic_controller(tmp_path, layout):
    """Feedback + adaptive harmonic control (case 3, switched on at 0.1 s): the recorder
    handshake covers ``harmonic/forces`` (one answer per sample, every message recorded), and
    the plant's topics equal the in-process run's (the harmonic forces were applied alike)."""
    path = tmp_path / "harmonic_short.yaml"
    path.write_text(yaml.safe_dump({"include": str(find_config("scenario_harmonic_case3_steady")),
                                    "harmonic": {"start_s": 0.1},
                                    "simulation": {"duration_s": 0.5}}))
    sc = str(path)
    run = run_graph(sc, tmp_path / "run.mcap", tmp_path / "logs", layout=layout, timeout_s=600)
    n = load_scenario(sc).n_steps
    assert run.steps == n and run.lost() == {}
    forces = next(t for t in run.counts if t.endswith("/harmonic/forces"))
    assert run.counts[forces]["published"] == run.counts[forces]["recorded"] >= n
    with BagReader(run.bag) as r:
        report = check_sequence(r)
    assert report.ok and report.samples == n, report.verdict()
    assert SAMPLED.match(forces)                   # checked for gaps like the plant's topics
    sim = tmp_path / "in_process.mcap"
    assert main(["simulate", sc, "--out", str(sim), "--per-sample"]) == 0
    graph, loop = messages_by_topic(run.bag), messages_by_topic(sim)
    assert len({t for t, _ in graph[forces]}) == n
    plant_topics = [t for t in loop if not t.endswith("/actuator_force")]
    assert len(plant_topics) >= 5
    for topic in plant_topics:
        assert graph[topic] == loop[topic], f"{topic} differs from the in-process loop's bag"


def test_ros_params_file_runs_the_graph(tmp_path):
    """config/ros_case3.yaml: every parameter it sets is declared by the node it names, and its
    scenario runs (shortened) through the launcher."""
    from rotor_avc.nodes import plant_simulator, recorder
    from rotor_avc.nodes.runtime import COMMON_PARAMS
    params = yaml.safe_load((ROOT / "config" / "ros_case3.yaml").read_text())
    declared = {"plant_simulator": plant_simulator.PARAMS, "recorder": recorder.PARAMS}
    common = {p.name for p in COMMON_PARAMS} | {"scenario", "namespace"}
    for node, section in params.items():
        names = {p.name for p in declared.get(node, ())} | common
        for key, value in section["ros__parameters"].items():
            assert key in names, f"{node}: {key} is not a declared parameter"
            match = next((p for p in declared.get(node, ()) if p.name == key), None)
            if match is not None and key != "path":
                assert match.check(value, node) == value
    base = params["/**"]["ros__parameters"]["scenario"]
    sc = short_scenario(tmp_path, base, speed={"type": "stepped", "speeds_hz": [17.18],
                                               "dwell_s": 0.2, "transition_s": 0.05})
    run = run_graph(sc, tmp_path / "run.mcap", tmp_path / "logs", timeout_s=600)
    assert run.lost() == {} and run.steps == load_scenario(sc).n_steps >= 1000


def plant_sample(listener, executor) -> int:
    executor.spin_once(timeout_sec=0.1)
    return listener["sample"]


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_a_recorder_stopping_mid_run_ends_the_lockstep_run(tmp_path, sig):
    """The plant (open loop, so it runs as fast as the recorder takes) ends with exit status 1
    and says at which sample the bag stops; a recorder ended by SIGINT/SIGTERM leaves a
    finished bag that holds a prefix of the run, gapless but for the sample it was taking when
    it stopped (whose messages on some topics had not arrived yet)."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rotor_avc.nodes.runtime import make_executor
    sc = scenario_file(tmp_path, "foot_mount_case2", 20.0, duration_s=60.0)
    bag = tmp_path / "run.mcap"
    rec = node_process("recorder", "-p", f"scenario:={sc}", "-p", f"path:={bag}")
    plant = node_process("plant_simulator", "-p", f"scenario:={sc}",
                         "-p", "wait_for_recorder:=recorder", "-p", "recorder_timeout_s:=5.0")
    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("test_progress", context=context)
    seen = {"sample": 0}

    def on_diag(msg):
        for st in msg.status:
            if st.name.endswith(": loop"):
                seen["sample"] = max(seen["sample"], int(next(
                    (kv.value for kv in st.values if kv.key == "sample"), 0)))
    node.create_subscription(DiagnosticArray, "/diagnostics", on_diag, 10)
    ex = make_executor("events", context=context)
    ex.add_node(node)
    try:
        t_end = time.monotonic() + 300
        while plant_sample(seen, ex) < 20_000 and time.monotonic() < t_end:
            assert plant.poll() is None and rec.poll() is None
        assert seen["sample"] >= 20_000, "the run did not get going"
        rec.send_signal(sig)
        plant_out = plant.communicate(timeout=120)[0]
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
        rec_out = stop(rec)
        stop(plant)
    assert plant.returncode == 1, plant_out
    assert "recorder 'recorder' disappeared" in plant_out or "took nothing" in plant_out
    assert "ENDED EARLY" in plant_out and "Traceback" not in plant_out
    if sig != signal.SIGKILL:
        assert rec.returncode == 0 and "Traceback" not in rec_out, rec_out
        with BagReader(bag) as r:
            report = check_sequence(r, 300_000)
        assert report.samples >= 20_000
        last = (report.samples - 1) * report.sample_period_s
        for gap in report.gaps:
            assert gap.ranges_s[0][0] >= last - 2e-3 and gap.missing <= 10, gap.describe()


def test_lost_messages_are_counted_and_said_everywhere(tmp_path):
    """Messages a publisher reports as published but the recorder never got (what happens when
    a recorder falls behind in real time) are said in the recorder's log and /diagnostics and
    written to the bag, whose sequence check then refuses it (exit status 3)."""
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import AccelStamped
    from ros_helpers import make_executor, params, spin_until
    from rotor_avc.nodes import messages as m
    from rotor_avc.nodes.recorder import Recorder
    rclpy.init()
    nodes, ex = [], make_executor("events")
    try:
        bag = tmp_path / "lossy.mcap"
        rec = Recorder("rec_lossy", parameter_overrides=params(
            scenario="scenario_case3_steady", path=str(bag)))
        driver = rclpy.create_node("driver_outside_the_package")   # a plain rclpy publisher
        watch = rclpy.create_node("diag_watch")
        nodes = [rec, driver, watch]
        topic = "/avc/foot/DL/acceleration"
        pub = driver.create_publisher(AccelStamped, topic, m.LOCKSTEP_QOS)
        diag = driver.create_publisher(DiagnosticArray, "/diagnostics", 10)
        said = []
        watch.create_subscription(DiagnosticArray, "/diagnostics", lambda a: said.extend(
            kv.key for st in a.status if st.name == "rec_lossy: recording" for kv in st.values),
            10)
        for n in nodes:
            ex.add_node(n)
        assert spin_until(ex, lambda: topic in rec.channels and pub.get_subscription_count() > 0)
        msg = m.StampedVector("acceleration", "DL")
        for k in range(100):
            pub.publish(msg.fill(k * 200_000, 1.0))
        assert spin_until(ex, lambda: rec.counts.get(topic) == 100)
        # the driver says it published 130 (30 never reached the recorder)
        assert spin_until(ex, lambda: diag.get_subscription_count() >= 2)
        diag.publish(m.diagnostics(0, [("driver_outside_the_package" + m.PUBLISHED_SUFFIX,
                                        "ok", "", {topic: 130})]))
        assert spin_until(ex, lambda: rec.losses() == {topic: 30})
        assert spin_until(ex, lambda: f"{topic} lost" in said, timeout_s=10)
    finally:
        ex.shutdown()
        for n in nodes:
            if n is nodes[0]:
                n.close()
            n.destroy_node()
        rclpy.shutdown()
    with BagReader(bag) as r:
        assert r.counts[topic] == {"published": 130, "recorded": 100, "lost": 30}
    assert main(["replay", str(bag), "--fast"]) == 3
