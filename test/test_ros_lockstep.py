"""Lockstep that stays lockstep, and one plant per namespace, in the graph of separate processes.

* A foot controller stopped (SIGSTOP: a GC pause, a loaded host) at a random sample and resumed
  (SIGCONT) once the plant says it waits for it: with the default ``fault_policy: wait`` the
  plant waits, says so, and the bag holds the ``simulate`` bag's messages byte for byte; with an
  explicit ``fault_policy: hold`` the run says it is not lockstep everywhere -- the plant's exit
  status 4, ``bag check``'s failed lockstep line naming the samples, ``compare`` refusing to
  rate it (exit status 6), ``replay --check`` failing.
* A controller that leaves the graph (SIGKILL) while the plant waits for it ends the run (exit
  status 5) naming it.
* A second plant on the namespace of a running graph is refused at start-up (one error line,
  exit status 6); the running graph is untouched.
* The recorder ends promptly on SIGTERM in every state -- waiting for discovery, recording, with
  the graph stalled on a stopped controller -- and always finishes its bag (summary, counts).
"""
import contextlib
import io
import random
import signal
import time
from pathlib import Path

import pytest

from ros_helpers import node_process, rclpy, stop, wait_for_nodes  # noqa: F401
from test_graph_recording import messages_by_topic
from test_ros_graph import scenario_file

from rotor_avc.bag import BagReader
from rotor_avc.bag.check import check_bag
from rotor_avc.bag.lockstep import EXIT_NOT_LOCKSTEP
from rotor_avc.cli import main
from rotor_avc.nodes.graph_nodes import graph_nodes
from rotor_avc.nodes.namespace_guard import EXIT_NAMESPACE_TAKEN
from rotor_avc.nodes.plant_params import EXIT_NODE_LEFT, EXIT_NOT_LOCKSTEP as PLANT_NOT_LOCKSTEP
from rotor_avc.scenario import load_scenario

pytestmark = pytest.mark.ros
#: the most a node may take to end after SIGTERM on this loaded machine (a hang is the failure;
#: the recorder drains for at most 3 s)
SIGTERM_BOUND_S = 20.0


class Plant:
    """The plant's ``/diagnostics`` (sample, loop status text) read in this process."""

    def __init__(self):
        from diagnostic_msgs.msg import DiagnosticArray
        from rotor_avc.nodes.runtime import make_executor
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("test_lockstep_watch", context=self.context)
        self.sample, self.texts = 0, []
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, 100)
        self.executor = make_executor("events", context=self.context)
        self.executor.add_node(self.node)

    def _on_diag(self, msg) -> None:
        for st in msg.status:
            if st.name == "plant_simulator: loop":
                values = {kv.key: kv.value for kv in st.values}
                self.sample = max(self.sample, int(values.get("sample", 0)))
                self.texts.append(st.message)
            elif st.name.startswith("plant_simulator: "):
                self.texts.append(st.message)

    def wait(self, condition, procs, timeout_s: float = 600.0) -> bool:
        """Spin until ``condition()``; False on timeout or when the plant process ended."""
        t_end = time.monotonic() + timeout_s
        while time.monotonic() < t_end:
            if condition():
                return True
            if procs["plant_simulator"].poll() is not None:
                return condition()
            self.executor.spin_once(timeout_sec=0.05)
        return False

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def start_graph(sc: str, bag: Path, plant_params: dict | None = None) -> dict:
    """The scenario's graph, one process per node (rotor_avc.nodes.graph_nodes), recorder first;
    the plant starts when the other nodes are in the graph."""
    procs = {}
    specs = graph_nodes(load_scenario(sc), bag, plant_params)
    for spec in specs[:-1]:
        procs[spec.name] = node_process(spec.executable, *spec.ros_args()[1:])
    assert wait_for_nodes([s.name for s in specs[:-1]], procs=procs.values())
    procs[specs[-1].name] = node_process(specs[-1].executable, *specs[-1].ros_args()[1:])
    return procs


def finish_graph(procs: dict) -> dict[str, str]:
    """Wait for the plant, then SIGINT the controllers and the recorder; every node's output."""
    out = {"plant_simulator": procs["plant_simulator"].communicate(timeout=600)[0]}
    for name, proc in procs.items():
        if name not in ("plant_simulator", "recorder"):
            out[name] = stop(proc, timeout_s=60)
    out["recorder"] = stop(procs["recorder"], timeout_s=60)
    return out


def kill_all(procs: dict) -> None:
    for proc in procs.values():
        if proc.poll() is None:
            proc.send_signal(signal.SIGCONT)
            proc.kill()
            proc.wait()


def paused_run(tmp_path, plant_params: dict, resume_when) -> tuple[str, Path, dict, int]:
    """A graph run with foot_controller_DL stopped at a random sample and resumed when
    ``resume_when(watch, k_stop)``; returns (scenario, bag, outputs, stop sample)."""
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=0.8)
    n = load_scenario(sc).n_steps
    k_stop = random.Random().randrange(200, n - 1500)
    bag = tmp_path / "run.mcap"
    watch = Plant()
    procs = start_graph(sc, bag, plant_params)
    try:
        assert watch.wait(lambda: watch.sample >= k_stop, procs), f"never reached {k_stop}"
        procs["foot_controller_DL"].send_signal(signal.SIGSTOP)
        assert watch.wait(lambda: resume_when(watch, k_stop), procs), watch.texts[-5:]
        procs["foot_controller_DL"].send_signal(signal.SIGCONT)
        out = finish_graph(procs)
    finally:
        kill_all(procs)
        watch.close()
    return sc, bag, out, k_stop


def test_a_paused_controller_is_waited_for_and_the_bag_equals_simulate(tmp_path):
    def said_waiting(watch, k_stop):
        return any("waiting" in t and "foot_controller_DL" in t for t in watch.texts)
    sc, bag, out, k_stop = paused_run(tmp_path, {}, said_waiting)
    plant = out["plant_simulator"]
    assert "waiting" in plant and "foot_controller_DL (DL)" in plant, plant
    assert "the run goes on in lockstep" in plant and "Traceback" not in plant
    assert "run complete:" in plant, plant
    sim = tmp_path / "simulate.mcap"
    assert main(["simulate", sc, "--out", str(sim), "--per-sample"]) == 0
    graph, loop = messages_by_topic(bag), messages_by_topic(sim)
    assert sorted(graph) == sorted(loop)
    for topic in loop:
        assert graph[topic] == loop[topic], f"{topic} differs from simulate (stop at {k_stop})"
    lines = check_bag(bag)
    assert [str(line) for line in lines if not line.ok] == []
    assert any(line.name == "lockstep" and line.ok for line in lines)
    with BagReader(bag) as r:
        assert r.lockstep.ok and r.lockstep.samples == load_scenario(sc).n_steps


def cli(*args) -> tuple[int, str, str]:
    """``rotor-avc ARGS``: (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(list(args))
    return status, out.getvalue(), err.getvalue()


def test_an_explicit_hold_policy_run_says_it_is_not_lockstep(tmp_path):
    def stepped_on(watch, k_stop):                   # DL absent, the plant stepped past it
        return any("no answer within" in t for t in watch.texts) and watch.sample > k_stop + 300
    sc, bag, out, k_stop = paused_run(
        tmp_path, {"fault_policy": "hold", "controller_timeout_s": 0.3}, stepped_on)
    plant = out["plant_simulator"]
    assert "NOT LOCKSTEP" in plant and f"exit status {PLANT_NOT_LOCKSTEP}" in plant, plant
    with BagReader(bag) as r:
        record = r.lockstep
    assert not record.ok and record.fault_policy == "hold" and record.substituted >= 1
    first = int(record.substituted_at.split("-")[0].split(",")[0])
    assert first >= k_stop, (k_stop, record.substituted_at)       # stopped after k_stop
    line = next(line for line in check_bag(bag) if line.name == "lockstep")
    assert not line.ok and record.substituted_at in line.detail and "hold" in line.detail
    status, out, _ = cli("bag", "check", str(bag))
    assert status != 0 and "PROBLEM  lockstep" in out and record.substituted_at in out
    status, _, err = cli("compare", str(bag), "--out", str(tmp_path / "cmp"))
    assert status == EXIT_NOT_LOCKSTEP and "not a lockstep run" in err, err
    assert record.substituted_at in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "cmp" / "index.html").exists()
    status, out, _ = cli("replay", str(bag), "--fast", "--check", "1e-12")
    assert status == 1 and "check: FAIL" in out and "NOT LOCKSTEP" in out, out


def test_the_plant_ends_the_run_when_a_controller_it_waits_for_leaves(tmp_path):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=0.8)
    bag = tmp_path / "run.mcap"
    watch = Plant()
    procs = start_graph(sc, bag)
    try:
        assert watch.wait(lambda: watch.sample >= 300, procs)
        procs["foot_controller_NL"].kill()
        out = finish_graph(procs)
    finally:
        kill_all(procs)
        watch.close()
    assert procs["plant_simulator"].returncode == EXIT_NODE_LEFT, out["plant_simulator"]
    assert "foot_controller_NL (NL) left the graph" in out["plant_simulator"]
    with BagReader(bag) as r:
        assert not r.lockstep.ok and "left the graph" in r.lockstep.verdict()


def test_a_second_plant_on_the_namespace_is_refused(tmp_path):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=60.0)
    bag = tmp_path / "run.mcap"
    watch = Plant()
    procs = start_graph(sc, bag)
    try:
        assert watch.wait(lambda: watch.sample >= 200, procs)
        second = procs["plant_two"] = node_process(
            "plant_simulator", "-r", "__node:=plant_two", "-p", f"scenario:={sc}")
        plant_out = second.communicate(timeout=300)[0]
        k_refused = watch.sample
        assert watch.wait(lambda: watch.sample > k_refused, procs)    # the run goes on
        assert procs["plant_simulator"].poll() is None
        for name in ("plant_simulator", *[n for n in procs if n.startswith("foot")], "recorder"):
            out = stop(procs[name], timeout_s=60)
            assert procs[name].returncode == 0, out
    finally:
        kill_all(procs)
        watch.close()
    errors = [line for line in plant_out.splitlines() if "ERROR" in line]
    assert second.returncode == EXIT_NAMESPACE_TAKEN, plant_out
    assert len(errors) == 1 and "publishes the plant's topics" in errors[0], plant_out
    assert "not starting" in errors[0] and "/plant_simulator" in plant_out
    assert "Traceback" not in plant_out
    with BagReader(bag) as r:                    # the refused plant never stepped: one plant
        assert r.lockstep.ok and r.lockstep.other_plants == ""


def sigterm_recorder(proc) -> str:
    proc.send_signal(signal.SIGTERM)
    out = proc.communicate(timeout=SIGTERM_BOUND_S)[0]
    assert proc.returncode == 0 and "Traceback" not in out, out
    return out


def test_the_recorder_ends_promptly_on_sigterm_in_every_state(tmp_path):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, duration_s=60.0)
    # waiting for discovery: nothing to record yet
    idle = tmp_path / "idle.mcap"
    rec = node_process("recorder", "-r", "__node:=recorder_idle", "-p", f"scenario:={sc}",
                       "-p", f"path:={idle}")
    try:
        assert wait_for_nodes(["recorder_idle"], procs=[rec])
        sigterm_recorder(rec)
    finally:
        stop(rec)
    with BagReader(idle) as r:
        assert r.counts is not None                     # finished: the counts are written
    # recording, then with the graph stalled on a stopped controller
    for state in ("recording", "stalled"):
        bag = tmp_path / f"{state}.mcap"
        watch = Plant()
        procs = start_graph(sc, bag)
        try:
            assert watch.wait(lambda: watch.sample >= 500, procs)
            if state == "stalled":
                procs["foot_controller_DL"].send_signal(signal.SIGSTOP)
                assert watch.wait(lambda: any("waiting" in t for t in watch.texts), procs)
            sigterm_recorder(procs["recorder"])
        finally:
            kill_all(procs)
            watch.close()
        with BagReader(bag, require_config=True) as r:
            assert r.counts and r.message_count > 500
