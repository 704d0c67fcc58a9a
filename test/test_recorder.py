"""The recorder node: under a 5 kHz lockstep run every published message is in the bag (per
topic), logged at its sim time, with the scenario's configuration; SIGINT/SIGTERM finish the file;
after SIGKILL at most the last chunk is lost and recover_bag rebuilds the bag; every recorded bag
is read by `rosbags` and by `mcap` + mcap-ros2-support, values equal to our reader's."""
import signal
from pathlib import Path

import numpy as np
import pytest

from ros_helpers import make_executor, node_process, params, rclpy, spin_until, stop  # noqa: F401
from test_ros_graph import FEET, scenario_file

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.serialization import serialize_message

from rotor_avc.bag import BagError, BagReader, recover_bag
from rotor_avc.bag.mcap_writer import MESSAGE_HEADER
from rotor_avc.bag.metadata import load_yaml
from rotor_avc.nodes import messages as m
from rotor_avc.nodes.foot_controller import FootController
from rotor_avc.nodes.plant_simulator import PlantSimulator
from rotor_avc.nodes.recorder import Recorder
from rotor_avc.scenario import load_scenario

pytestmark = pytest.mark.ros
T_NS = 200_000                       # 5 kHz


@pytest.fixture(scope="module", autouse=True)
def ros():
    rclpy.init()
    yield
    rclpy.shutdown()


def test_raw_time_reader_equals_the_deserialised_stamp():
    """The recorder's log time read from the CDR bytes equals the message's own sim time."""
    t_ns = 12_345_678_901
    cases = [(m.Rotor().fill(t_ns, 1.0, 2.0)[0], "sensor_msgs/msg/JointState"),
             (m.Rotor().fill(t_ns, 1.0, 2.0)[1], "rosgraph_msgs/msg/Clock"),
             (m.diagnostics(t_ns, [("x", "ok", "y", {"a": 1.0})]),
              "diagnostic_msgs/msg/DiagnosticArray")]
    for kind, cls in m.STAMPED_TYPES.items():
        msg = cls()
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t_ns, 10**9)
        cases.append((msg, f"geometry_msgs/msg/{cls.__name__}"))
        # the nodes' own serialised messages (StampedVector) carry the same stamp
        raw = m.StampedVector(kind, "NR").fill(t_ns, -1.0)
        assert m.raw_time_reader(f"geometry_msgs/msg/{cls.__name__}")(raw) == t_ns
        assert m.stamped_value(raw) == (t_ns, -1.0)
    for msg, msg_type in cases:
        assert m.raw_time_reader(msg_type)(serialize_message(msg)) == t_ns, msg_type
    labelled = m.raw_time_reader("std_msgs/msg/Float64MultiArray")
    for names in (["time_s"], ["time_s", "a"], ["time_s", "bearing_D_vz", "x" * 37]):
        msg = m.Labelled(names).fill([t_ns * 1e-9] + [7.0] * (len(names) - 1))
        assert labelled(serialize_message(msg)) == t_ns, names
    for names in (["time_sx", "a"], ["a", "time_s"]):           # no leading time_s: no time
        assert labelled(serialize_message(m.Labelled(names).fill([1.0, 2.0]))) is None
    assert m.raw_time_reader("std_msgs/msg/String")(b"\x00\x01\x00\x00abcd") is None


def expected_counts(plant, ctrls) -> dict:
    """Messages published per lockstep topic, as the publishing nodes count them: the plant
    publishes every sample once plus its resends, each controller answers every measurement."""
    per_sample = plant.n_steps + plant.book.resends
    out = {pub.topic_name: per_sample for pub, _, _ in plant.meas}
    for pub in (plant.pub_joint, plant.pub_clock, plant.pub_obs):
        out[pub.topic_name] = per_sample
    for c in ctrls:
        out[c.pub.topic_name] = plant.n_steps + sum(c.faults.values())
    return out


def run_graph(executor, sc: str, name: str, **plant_params):
    """Plant and the three controllers of case 3 in ``executor``; returns (plant, controllers)."""
    plant = PlantSimulator(name, parameter_overrides=params(scenario=sc, **plant_params))
    ctrls = [FootController(f"{name}_fc_{f}", parameter_overrides=params(scenario=sc, foot_id=f))
             for f in FEET]
    for n in (plant, *ctrls):
        executor.add_node(n)
    return plant, ctrls


def lockstep_topics(counts: dict) -> dict:
    return {k: v for k, v in counts.items() if k != "/diagnostics"}


def same(ours, theirs) -> bool:
    """Our reader's decoded message (dicts, numpy arrays) equals another reader's object."""
    if isinstance(ours, dict):
        return all(same(v, getattr(theirs, k)) for k, v in ours.items())
    if isinstance(ours, np.ndarray):
        return np.array_equal(ours, np.asarray(theirs, dtype=ours.dtype))
    if isinstance(ours, list):
        return len(ours) == len(theirs) and all(same(a, b) for a, b in zip(ours, theirs))
    if isinstance(theirs, bytes) and isinstance(ours, int):      # a `byte` field
        return theirs == bytes([ours])
    return ours == theirs


def check_other_readers(path: Path, counts: dict) -> None:
    """rosbags' AnyReader and mcap's reader with mcap-ros2-support's decoder decode every
    message; each equals our reader's message of the same topic and log time."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from rosbags.highlevel import AnyReader
    ours: dict = {}
    with BagReader(path) as r:
        for msg in r.messages():
            ours.setdefault((msg.topic, msg.time_ns), []).append(msg.data)

    def match(key, obj, pending):
        candidates = pending.get(key, [])
        for i, mine in enumerate(candidates):       # ties of one log time in any order
            if same(mine, obj):
                del candidates[i]
                return True
        return False

    pending = {k: list(v) for k, v in ours.items()}
    with AnyReader([path]) as reader:
        assert {c.topic: c.msgcount for c in reader.connections} == counts
        for conn, t_ns, raw in reader.messages():
            assert match((conn.topic, t_ns), reader.deserialize(raw, conn.msgtype), pending), \
                (conn.topic, t_ns)
    assert not any(pending.values())
    pending = {k: list(v) for k, v in ours.items()}
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
            assert match((channel.topic, message.log_time), decoded, pending), channel.topic
    assert not any(pending.values())


def test_lockstep_run_records_every_message(tmp_path):
    """5 kHz lockstep, plant + 3 controllers + recorder in one executor: the plant waits for
    the recorder; per topic the bag holds exactly what was published, at its sim time, with
    the values of the run and the scenario's configuration; three readers agree."""
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=0.5)
    path = tmp_path / "run.mcap"
    ex = make_executor("events")
    plant, ctrls = run_graph(ex, sc, "plant_rec", wait_for_recorder="recorder")
    rec = None
    try:
        spin_until(ex, lambda: False, timeout_s=0.5)
        assert not plant.started                         # no recorder yet: sample 0 waits
        rec = Recorder("recorder", parameter_overrides=params(scenario=sc, path=str(path)))
        ex.add_node(rec)
        assert spin_until(ex, lambda: plant.finished, timeout_s=120)
        expected = expected_counts(plant, ctrls)
        assert spin_until(ex, lambda: lockstep_topics(rec.counts) == expected, timeout_s=10)
        spin_until(ex, lambda: False, timeout_s=0.2)     # nothing more arrives
        assert lockstep_topics(rec.counts) == expected
    finally:
        ex.shutdown()
        for n in (plant, *ctrls):
            n.destroy_node()
        if rec is not None:
            rec.close()
            rec.destroy_node()
    assert plant.n_steps == 2500 and not plant.fault_log
    ts = plant.result()
    t_ns = np.arange(plant.n_steps) * T_NS
    with BagReader(path, require_config=True, require_messages=True) as r:
        counts = {k: v.count for k, v in r.topics.items()}
        assert lockstep_topics(counts) == expected and counts["/diagnostics"] >= 1
        config = load_scenario(sc).run_config()
        for key in ("controllers", "discretisation", "speed_profile", "unbalance"):
            assert r.config[key] == config[key], key
        assert r.config["machine"]["name"] == "foot_mount_case3"
        assert r.config["package_version"]
        for f in FEET:
            acc = r.series(m.actuator_topic(f, "acceleration"))
            np.testing.assert_array_equal(acc.time_ns, t_ns)
            np.testing.assert_array_equal(acc["accel.linear.z"], ts[f"foot_{f}_az"])
            force = r.series(m.actuator_topic(f, "actuator_force"))
            np.testing.assert_array_equal(force.time_ns, t_ns)
            np.testing.assert_array_equal(force["wrench.force.z"], ts[f"actuator_{f}_fz"])
        obs = r.series("/avc/plant/observables")
        np.testing.assert_array_equal(obs.time_ns, t_ns)
        for name in ("bearing_D_vz", "foundation_DL_vz", "foot_NL_az"):
            np.testing.assert_array_equal(obs[name], ts[name])
        joint = r.series("/avc/rotor/joint_state")
        np.testing.assert_array_equal(joint["position[0]"], ts.angle_rad)
        np.testing.assert_array_equal(r.series("/clock").time_ns, t_ns)
        qos = r.topics["/avc/foot/DL/acceleration"].qos[0]
        assert qos["reliability"] == "reliable" and qos["durability"] == "transient_local"
    check_other_readers(path, counts)


class RecorderWatch:
    """Reads the recorder's per-topic counts from its /diagnostics."""

    def __init__(self):
        self.node = rclpy.create_node("recorder_watch")
        self.counts: dict = {}
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, 100)

    def _on_diag(self, arr) -> None:
        for st in arr.status:
            if st.name == "recorder: recording":
                self.counts = {kv.key[:-len(" recorded")]: int(kv.value) for kv in st.values
                               if kv.key.endswith(" recorded")}


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_recorder_process_ends_on_signals(tmp_path, sig):
    """A recorder process records a lockstep run (plant and controllers in this process);
    SIGINT/SIGTERM finish the file with every message; SIGKILL loses at most the last chunk
    and recover_bag rebuilds a readable bag of the rest."""
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=0.2)
    path = tmp_path / "rec.mcap"
    chunk = 16384
    proc = node_process("recorder", "-p", f"scenario:={sc}", "-p", f"path:={path}",
                        "-p", f"chunk_size_bytes:={chunk}")
    ex = make_executor("events")
    watch = RecorderWatch()
    ex.add_node(watch.node)
    plant, ctrls = run_graph(ex, sc, "plant_sig", wait_for_recorder="recorder")
    try:
        assert spin_until(ex, lambda: plant.finished, timeout_s=120), "recorder never subscribed"
        expected = expected_counts(plant, ctrls)
        assert spin_until(ex, lambda: lockstep_topics(watch.counts) == expected, timeout_s=20), \
            (watch.counts, expected)
        proc.send_signal(sig)
        out, _ = proc.communicate(timeout=30)
    finally:
        log = stop(proc)
        ex.shutdown()
        for n in (plant, *ctrls, watch.node):
            n.destroy_node()
    assert "Traceback" not in (out or "") + log
    if sig != signal.SIGKILL:
        assert proc.returncode == 0, out
        with BagReader(path, require_config=True) as r:          # summary present
            counts = {k: v.count for k, v in r.topics.items()}
            assert lockstep_topics(counts) == expected
            assert load_yaml(r.metadata["rosbag2"]["serialized_metadata"])["message_count"] \
                == r.message_count
        check_other_readers(path, counts)
        return
    assert proc.returncode == -signal.SIGKILL
    with pytest.raises(BagError, match="truncated.*recover_bag"):
        BagReader(path)
    recovery = recover_bag(path)
    lost_bytes = 0
    with BagReader(recovery.path, require_config=True) as r:
        assert r.config["controllers"] == load_scenario(sc).run_config()["controllers"]
        for topic, n_published in expected.items():
            if r.topics.get(topic) is None or r.topics[topic].count == 0:
                lost_bytes += n_published * 60      # a lower bound of its record size
                continue
            got = r.series(topic)
            n = len(got.time_ns)
            np.testing.assert_array_equal(got.time_ns, np.arange(n) * T_NS)   # a prefix
            size = MESSAGE_HEADER.size + len(next(r.raw_messages(topic)).data)
            lost_bytes += (n_published - n) * size
    assert recovery.messages > 0
    assert lost_bytes < chunk, f"{lost_bytes} bytes of messages lost: more than one chunk"
    with BagReader(recovery.path) as r:
        counts = {k: v.count for k, v in r.topics.items()}
    check_other_readers(recovery.path, counts)


def test_recorder_refuses_bad_parameters(tmp_path):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0)
    exists = tmp_path / "exists.mcap"
    exists.write_bytes(b"x")
    with pytest.raises(BagError, match="file exists"):
        Recorder("rec_exists", parameter_overrides=params(scenario=sc, path=str(exists)))
    with pytest.raises(Exception, match="parameter 'path' is empty"):
        Recorder("rec_nopath", parameter_overrides=params(scenario=sc))
    proc = node_process("recorder", "-p", f"path:={tmp_path / 'x.mcap'}")
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 2 and "'scenario' is empty" in out and "Traceback" not in out
