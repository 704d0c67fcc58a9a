"""`rotor-avc replay`: a foot controller re-driven with a bag's recorded foot accelerations
publishes the recorded forces (same filter, same inputs: equal to 1e-12), a changed controller is
detected, a rosbag2 directory with driver topics re-drives it through --remap, timed replay
keeps the recorded timing, a rate it cannot hold is said with the achieved rate and does not
fail the check, an earlier replay's answers are not taken for a later one's, and malformed bags
give a one-line error."""
import itertools
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from rosbag2_corpus import write_split_bag
from ros_helpers import ROOT, make_executor, node_process, params, rclpy, spin_until, stop
from test_ros_graph import scenario_file

from geometry_msgs.msg import AccelStamped, WrenchStamped
from rclpy.serialization import deserialize_message

from rotor_avc.bag import BagReader, BagWriter, topics as T
from rotor_avc.bag.mcap_writer import McapSink
from rotor_avc.bag.rosbag2 import open_bag
from rotor_avc.cli import main as cli
from rotor_avc.nodes import messages as m
from rotor_avc.nodes.foot_controller import FootController
from rotor_avc.nodes.recorder import RECORD_QOS
from rotor_avc.nodes.replay import (LATE_S, AnswerRule, Replayer, ReplayError, ReplayResult,
                                    plan_replay)
from rotor_avc.nodes.replay_check import compare_answers
from rotor_avc.nodes.replay_timing import read_ahead as _read_ahead

pytestmark = pytest.mark.ros
DL_ACC, DL_FORCE = "/avc/foot/DL/acceleration", "/avc/foot/DL/actuator_force"


@pytest.fixture(scope="module", autouse=True)
def ros():
    rclpy.init()
    yield
    rclpy.shutdown()


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A 0.2 s case-3 run at 5 kHz (1000 samples) as a bag from `rotor-avc simulate
    --per-sample` (the controllers stepped as the nodes step them: answers equal to the last bit)."""
    tmp = tmp_path_factory.mktemp("replay")
    sc = scenario_file(tmp, "foot_mount_case3", 20.0, duration_s=0.2)
    bag = tmp / "case3.mcap"
    assert cli(["simulate", sc, "--out", str(bag), "--per-sample"]) == 0
    return sc, bag


@pytest.fixture(scope="module")
def long_run(tmp_path_factory):
    """A 2 s case-3 run at 5 kHz (10,000 samples): more answers than the lockstep queues hold
    (LOCKSTEP_DEPTH 4096)."""
    tmp = tmp_path_factory.mktemp("replay_long")
    sc = scenario_file(tmp, "foot_mount_case3", 20.0, duration_s=2.0)
    bag = tmp / "case3_long.mcap"
    assert cli(["simulate", sc, "--out", str(bag), "--per-sample"]) == 0
    return sc, bag


def changed_gain(tmp_path, sc: str) -> str:
    """A copy of the scenario whose DL controller has another gain."""
    path = Path(sc).parent / f"changed_{tmp_path.name}.yaml"     # beside it: includes stay
    path.write_text(f"include: {Path(sc).name}\ncontrollers:\n"
                    "  DL: {type: I, feedback: acceleration, ki: 1.5e+5}\n")
    return str(path)


def test_controller_redriven_by_the_bag_gives_the_recorded_forces(run):
    """Lockstep replay of DL's and DR's accelerations into a DL controller node (one executor):
    its forces equal the recorded ones to 1e-12 N, stamp by stamp; DR (no controller running)
    is not waited for."""
    sc, bag = run
    ctrl = FootController("fc_replay_DL", parameter_overrides=params(scenario=sc, foot_id="DL"))
    ex = make_executor("events")
    ex.add_node(ctrl)
    with BagReader(bag, require_config=True) as reader:
        plan = plan_replay(reader, [DL_ACC, "/avc/foot/DR/acceleration"])
        node = Replayer(reader, plan)
        ex.add_node(node)
        try:
            result = node.run(ex, fast=True, discovery_timeout_s=2.0)   # DR: none comes
        finally:
            ex.shutdown()
            node.destroy_node()
            ctrl.destroy_node()
        recorded = reader.series(DL_FORCE)
        checks = compare_answers(reader, plan, result)
    assert result.waited_for == {DL_ACC: DL_FORCE}
    assert result.unanswered == ["/avc/foot/DR/acceleration"]
    assert result.published == {DL_ACC: 1000, "/avc/foot/DR/acceleration": 1000}
    assert result.samples == 1000 and not result.missing
    live = [deserialize_message(data, WrenchStamped) for _, data in result.answers[DL_FORCE]]
    stamps = np.array([m.stamp_ns(w.header.stamp) for w in live])
    np.testing.assert_array_equal(stamps, recorded.time_ns)
    force = np.array([w.wrench.force.z for w in live])
    assert np.max(np.abs(force - recorded["wrench.force.z"])) <= 1e-12
    assert np.max(np.abs(force)) > 10.0                   # real forces, not zeros
    (check,) = checks
    assert check.compared == 1000 and check.passed(1e-12)


def test_a_rosbag2_directory_with_driver_topics_redrives_a_controller(tmp_path, run):
    """A `ros2 bag record`-style directory (rosbags' writer, two split files) whose DL
    accelerations are on a driver's topic: replayed with the topic remapped onto the
    controller's input, the controller answers every sample with the recorded force."""
    sc, bag = run
    with BagReader(bag) as reader:
        messages = [(msg.time_ns, "/accel_dl/data", reader.topics[DL_ACC].msg_type, msg.data)
                    for msg in reader.raw_messages(DL_ACC)]
        recorded = reader.series(DL_FORCE)
    directory = write_split_bag(tmp_path / "recording", messages)
    ctrl = FootController("fc_dir_DL", parameter_overrides=params(scenario=sc, foot_id="DL"))
    ex = make_executor("events")
    ex.add_node(ctrl)
    with open_bag(directory) as reader:
        plan = plan_replay(reader, ["/accel_dl/data"], {"/accel_dl/data": DL_ACC})
        node = Replayer(reader, plan)
        ex.add_node(node)
        try:
            result = node.run(ex, fast=True, discovery_timeout_s=2.0)
        finally:
            ex.shutdown()
            node.destroy_node()
            ctrl.destroy_node()
    assert result.waited_for == {DL_ACC: DL_FORCE} and result.published == {DL_ACC: 1000}
    live = [deserialize_message(data, WrenchStamped) for _, data in result.answers[DL_FORCE]]
    np.testing.assert_array_equal([m.stamp_ns(w.header.stamp) for w in live], recorded.time_ns)
    force = np.array([w.wrench.force.z for w in live])
    assert np.max(np.abs(force - recorded["wrench.force.z"])) <= 1e-12


@pytest.mark.parametrize("changed", [False, True])
def test_replay_command_checks_a_controller(tmp_path, run, changed):
    """The command line as a user runs it (controller and replay in their own processes):
    `--check` passes for the recorded controller and fails for one with another gain (replayed
    with --force: its configuration is not the bag's, which replay would refuse)."""
    sc, bag = run
    config = changed_gain(tmp_path, sc) if changed else sc
    ctrl = node_process("foot_controller", "-r", "__node:=fc_check_DL", "-p", f"scenario:={config}",
                        "-p", "foot_id:=DL")
    try:
        proc = subprocess.run([sys.executable, "-m", "rotor_avc", "replay", str(bag), "--fast",
                               "--topics", DL_ACC, "--check", "1e-12", "--discovery-timeout", "30"]
                              + (["--force"] if changed else []),
                              cwd=ROOT, capture_output=True, text=True, timeout=180)
    finally:
        log = stop(ctrl)
    assert "Traceback" not in proc.stderr + log, proc.stderr + log
    assert f"{DL_ACC} -> {DL_FORCE}" in proc.stdout
    if changed:
        assert proc.returncode == 1 and f"FAIL on {DL_FORCE}" in proc.stdout, proc.stdout
        assert "  controllers.DL.ki: bag 140000, node 150000\n" in proc.stdout
    else:
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert "1000 answers, 1000 compared" in proc.stdout
        assert "every answer equals the recording" in proc.stdout


def test_timed_replay_keeps_the_recorded_timing(run):
    """`rotor-avc replay --rate 0.5` (its own process): the 0.2 s of DL accelerations take
    0.4 s at a listener here -- every message, on the scaled schedule (none ahead of it, and no
    drift from it), values and order as recorded, under the remapped name."""
    _, bag = run
    rate = 0.5
    topic = "/timed/foot/DL/acceleration"
    got = []
    listener = rclpy.create_node("timed_listener")
    listener.create_subscription(
        AccelStamped, topic,
        lambda msg: got.append((time.monotonic(), m.stamp_ns(msg.header.stamp),
                                msg.accel.linear.z)), RECORD_QOS)    # KEEP_ALL: none dropped
    ex = make_executor("events")
    ex.add_node(listener)
    proc = subprocess.Popen([sys.executable, "-m", "rotor_avc", "replay", str(bag), "--rate",
                             str(rate), "--topics", DL_ACC, "--remap", f"{DL_ACC}:={topic}",
                             "--discovery-timeout", "30"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        assert spin_until(ex, lambda: len(got) == 1000 or proc.poll() is not None, timeout_s=90)
        spin_until(ex, lambda: len(got) == 1000, timeout_s=2)
        out, _ = proc.communicate(timeout=30)
    finally:
        log = stop(proc)
        ex.shutdown()
        listener.destroy_node()
    assert proc.returncode == 0 and "Traceback" not in out + log, out + log
    assert "published 1000 messages at 1000 log times" in out
    with BagReader(bag) as reader:
        recorded = reader.series(DL_ACC)
    arrival, stamps, values = (np.array(c) for c in zip(*got))
    np.testing.assert_array_equal(stamps, recorded.time_ns)
    np.testing.assert_array_equal(values, recorded["accel.linear.z"])
    schedule = (stamps - stamps[0]) * 1e-9 / rate
    lateness = arrival - schedule                   # + a constant: when the replay started
    # a delivery's delay has a floor (the replay's start) and a long tail on a busy machine. A
    # late start is caught up (the schedule is absolute: the floor falls early on); after that
    # the floor stays put over the second half of the run: the replay neither runs ahead of the
    # scaled schedule (the floor would fall: slope -1 + rate_used / rate) nor drifts behind it
    # (it would rise). The slope is the median of the pairwise slopes of the second half's
    # tenths (Theil-Sen), so a moment of stalling on a loaded machine does not decide it
    floors = np.array([np.min(part) for part in np.array_split(lateness, 10)])
    centres = np.array([np.mean(part) for part in np.array_split(schedule, 10)])
    slope = np.median([(floors[j] - floors[i]) / (centres[j] - centres[i])
                       for i in range(5, 10) for j in range(i + 1, 10)])
    assert abs(slope) < 0.05, (slope, floors)


def test_plan_errors_name_the_topic_and_fix(run):
    _, bag = run
    with BagReader(bag) as reader:
        with pytest.raises(ReplayError, match="no topic /nope in the bag.*use one of"):
            plan_replay(reader, ["/nope"])
        with pytest.raises(ReplayError, match="--remap names /clock, which is not replayed"):
            plan_replay(reader, [DL_ACC], {"/clock": "/c2"})
        with pytest.raises(ReplayError, match="not an absolute topic name"):
            plan_replay(reader, [DL_ACC], {DL_ACC: "acc"})
        plan = plan_replay(reader, [DL_ACC, DL_FORCE], {DL_ACC: "/re/foot/DL/acceleration"})
        assert plan.topics[DL_ACC] == "/re/foot/DL/acceleration"
        # the remapped trigger is answered on the remapped namespace; compared with the bag's
        assert plan.answers["/re/foot/DL/acceleration"].topic == "/re/foot/DL/actuator_force"
        assert plan.answers["/re/foot/DL/acceleration"].recorded == DL_FORCE
        plan = plan_replay(reader, [DL_ACC, DL_FORCE])
        assert plan.answers == {}                       # the answer is replayed itself
        rule = AnswerRule.exact(DL_ACC, "/my/answer")
        assert plan_replay(reader, [DL_ACC], rules=[rule]).answers[DL_ACC].topic == "/my/answer"


def _bag_with_unknown_schema(path):
    config = {"machine": {"model": "foot_mount_3d"}}
    with BagWriter(path, config) as w:
        w.write_streams([T.foot_acceleration("DL", np.arange(3) * 1e-3, np.zeros(3))])
    raw = path.read_bytes()
    foreign = path.with_name("foreign.mcap")
    with open(foreign, "wb") as f:
        sink = McapSink(f, "ros2", "test")
        from rotor_avc.bag.metadata import encode_config
        sink.add_metadata("rotor_avc", encode_config(config))
        sid = sink.add_schema("foo_msgs/msg/Bar", "ros2msg", b"foo_msgs/Baz baz\n")
        cid = sink.add_channel("/avc/foo", "cdr", sid, {})
        sink.add_message(cid, 5, 5, 1, b"\x00\x01\x00\x00" + bytes(8))
        sink.finish()
    return raw, foreign


def test_malformed_bags_give_one_line_errors(tmp_path, run, capsys):
    _, bag = run
    raw = bag.read_bytes()
    cases = {}
    cases["truncated"] = tmp_path / "cut.mcap"
    cases["truncated"].write_bytes(raw[:len(raw) // 2])
    _, cases["unknown schema"] = _bag_with_unknown_schema(tmp_path / "ok.mcap")
    cases["holds no messages"] = tmp_path / "nomsg.mcap"
    with BagWriter(cases["holds no messages"], {"machine": {"model": "x"}}) as w:
        w.add_topic(DL_ACC)
    cases["empty file"] = tmp_path / "zero.mcap"
    cases["empty file"].write_bytes(b"")
    for problem, path in cases.items():
        assert cli(["replay", str(path), "--fast"]) == 2, problem
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and problem in err and "fix:" in err, err
        assert err.startswith("rotor-avc replay: error: ")


def test_compare_answers_matches_stamps_and_flags_every_difference(run):
    """The regression check itself (no ROS traffic): answers equal to the recording pass; a
    changed value, a NaN, a missing answer or an answer of a stamp never recorded fail."""
    _, bag = run
    with BagReader(bag) as reader:
        plan = plan_replay(reader, [DL_ACC])
        recorded = [(msg.time_ns, msg.data) for msg in reader.raw_messages(DL_FORCE)]

        def check(answers, missing=0):
            result = ReplayResult("lockstep", {DL_ACC: 1000}, 1000, 1.0, {DL_ACC: DL_FORCE}, [],
                                  answers={DL_FORCE: answers},
                                  missing={DL_FORCE: missing} if missing else {})
            (c,) = compare_answers(reader, plan, result)
            return c

        same_answers = check(recorded + recorded[:5])          # repeated stamps count once
        assert same_answers.compared == 1000 and same_answers.passed(0.0)
        stamp, value = m.stamped_value(recorded[500][1])
        for bad, why in ((value + 1e-9, "changed"), (float("nan"), "nan")):
            answers = list(recorded)
            answers[500] = (stamp, m.Force("DL").fill(stamp, bad))
            c = check(answers)
            assert not c.passed(1e-12), why
            assert c.max_abs_diff == (pytest.approx(1e-9, rel=1e-3) if why == "changed"
                                      else float("inf"))
        assert not check(recorded[:-1], missing=1).passed(1.0)
        stray = check(recorded + [(10**15, m.Force("DL").fill(10**15, 0.0))])
        assert stray.unmatched == 1 and not stray.passed(1.0)


def test_a_rate_the_replay_cannot_hold_is_said_and_does_not_fail_the_check(long_run):
    """`rotor-avc replay --rate 10 --check` of 10,000 samples (50,000 messages/s asked, far
    beyond a Python publisher) into a controller process: a warning gives the achieved rate and
    the late log times, and every answer arrives and equals the recording (exit 0) -- the
    answers were once left to overflow the queues, 5,554 of them lost and the check failed."""
    sc, bag = long_run
    ctrl = node_process("foot_controller", "-r", "__node:=fc_rate_DL", "-p", f"scenario:={sc}",
                        "-p", "foot_id:=DL")
    try:
        proc = subprocess.run([sys.executable, "-m", "rotor_avc", "replay", str(bag), "--rate",
                               "10", "--topics", DL_ACC, "--check", "1e-12",
                               "--discovery-timeout", "30", "--answer-timeout", "60"],
                              cwd=ROOT, capture_output=True, text=True, timeout=600)
    finally:
        log = stop(ctrl)
    out = proc.stdout + proc.stderr
    assert "Traceback" not in out + log, out + log
    warning = [line for line in proc.stdout.splitlines() if line.startswith("warning: ")]
    assert len(warning) == 1 and "could not hold --rate 10: achieved " in warning[0], out
    assert "x of the requested 10x; " in warning[0] and " of 10000 log times published" in out
    assert proc.returncode == 0, out
    assert "10000 answers, 10000 compared" in out and "0 triggers unanswered" in out, out
    assert "every answer equals the recording" in out


def test_rate_warning_counts_the_late_log_times():
    result = ReplayResult("timed x10", {DL_ACC: 100}, 100, 3.0, {}, [], rate=10.0,
                          achieved_rate=0.3125, late=97, max_lag_s=2.5)
    assert result.rate_warning() == (
        f"could not hold --rate 10: achieved 0.31x of the requested 10x; 97 of 100 log times "
        f"published more than {LATE_S:g} s late (up to 2.5 s behind the schedule)")
    held = ReplayResult("timed x0.5", {DL_ACC: 100}, 100, 3.0, {}, [], rate=0.5,
                        achieved_rate=0.5, late=0, max_lag_s=0.01)
    assert held.rate_warning() is None
    assert ReplayResult("lockstep", {DL_ACC: 100}, 100, 3.0, {}, []).rate_warning() is None


def test_a_later_replay_takes_only_its_own_answers(run):
    """Two lockstep replays into one controller node: the second receives its own 1000 answers
    only -- not also the 1000 the controller gave the first one (history a transient-local
    subscription would deliver) -- and, the controller having run on from the first replay
    (stale stamps, then a reset), they differ from the recording: the check fails, as it must."""
    sc, bag = run
    ctrl = FootController("fc_twice_DL", parameter_overrides=params(scenario=sc, foot_id="DL"))
    ex = make_executor("events")
    ex.add_node(ctrl)
    results = []
    with BagReader(bag, require_config=True) as reader:
        plan = plan_replay(reader, [DL_ACC])
        try:
            for k in range(2):
                node = Replayer(reader, plan, name=f"rotor_avc_replay_{k}")
                ex.add_node(node)
                try:
                    results.append(node.run(ex, fast=True, discovery_timeout_s=5.0))
                finally:
                    ex.remove_node(node)
                    node.destroy_node()
        finally:
            ex.shutdown()
            ctrl.destroy_node()
        checks = [compare_answers(reader, plan, r)[0] for r in results]
    # one answer per stamp sent, and one more for each trigger sent again on a busy machine
    assert [len({stamp for stamp, _ in r.answers[DL_FORCE]}) for r in results] == [1000, 1000]
    assert all(len(r.answers[DL_FORCE]) <= 1000 + r.resends for r in results)
    assert checks[0].passed(1e-12) and not checks[1].passed(1e-12)
    assert results[0].foreign == {}     # nothing but its own answers reached the first replay


def test_read_ahead_hands_over_items_and_errors_and_stops_when_closed():
    """The timed replay's reader thread: every item in order, a reading error (a damaged chunk)
    raised in the consumer after the items before it, and a consumer that stops early ends the
    thread (and the interpreter's switch interval is restored)."""
    interval = sys.getswitchinterval()

    def damaged():
        yield from range(3)
        raise ValueError("damaged chunk")
    assert list(_read_ahead(iter(range(10_000)), 64)) == list(range(10_000))
    got = []
    with pytest.raises(ValueError, match="damaged chunk"):
        for item in _read_ahead(damaged(), 64):
            got.append(item)
    assert got == [0, 1, 2]
    endless = _read_ahead(itertools.count(), 16)
    assert next(endless) == 0
    endless.close()                                       # joins the thread
    assert not [t for t in threading.enumerate() if t.name == "replay_read_ahead"]
    assert sys.getswitchinterval() == interval
