"""README's replay recipe runs as written (its lines between the `replay-recipe` markers, the
node through its console script, waited for by its ready line) against the committed reference
bag, and a node that does not run the bag's configuration is refused before anything is
published (exit status 2, the differing field with both values and the command that fixes it),
replayed with --force (the difference said in the verdict), and answers as recorded once started
with the printed command; the query itself reads each answering node's parameter (an older
node: none)."""
import os
import queue
import re
import shlex
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from ros_helpers import ROOT, params, rclpy, spin_until

from geometry_msgs.msg import WrenchStamped

from rotor_avc.compare.answer_config import answer_config
from rotor_avc.config import find_config
from rotor_avc.nodes.signals import spawn
from rotor_avc.scenario import load_scenario

pytestmark = pytest.mark.ros
DL_ACC, DL_FORCE = "/avc/foot/DL/acceleration", "/avc/foot/DL/actuator_force"
READY_TIMEOUT_S = 120.0
COMMAND_TIMEOUT_S = 180.0


def readme_recipe() -> list[str]:
    """The command lines of README.md between ``<!-- replay-recipe -->`` and
    ``<!-- /replay-recipe -->`` (the fenced block's lines)."""
    text = (ROOT / "README.md").read_text()
    found = re.search(r"<!-- replay-recipe -->\n```sh\n(.*?)```\n<!-- /replay-recipe -->", text,
                      re.DOTALL)
    assert found, "README.md lost its replay recipe markers"
    return [line for line in found.group(1).splitlines() if line.strip()]


def console_script(argv: list[str]) -> list[str]:
    """``argv`` with its program resolved as the shell would, from this interpreter's
    environment first (the venv's console scripts)."""
    local = Path(sys.executable).parent / argv[0]
    program = str(local) if local.is_file() else shutil.which(argv[0])
    assert program, f"console script {argv[0]} is not installed"
    return [program] + argv[1:]


class NodeProcess:
    """A node started in the background from a command line (``... &``), its output read by a
    thread; :meth:`wait_ready` waits for its ready line (rotor_avc.nodes.runtime.ready_line)."""

    def __init__(self, line: str):
        self.proc = spawn(console_script(shlex.split(line)), cwd=ROOT, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True,
                          env={**os.environ, "PYTHONUNBUFFERED": "1"})
        self.lines: queue.Queue = queue.Queue()
        self.output: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def wait_ready(self) -> None:
        t_end = time.monotonic() + READY_TIMEOUT_S
        while time.monotonic() < t_end:
            try:
                line = self.lines.get(timeout=max(t_end - time.monotonic(), 0.01))
            except queue.Empty:
                break
            if line is None:
                break
            self.output.append(line)
            if "ready: " in line:
                return
        pytest.fail("node not ready in time (or ended):\n" + "".join(self.output))

    def stop(self, timeout_s: float = 10.0) -> str:
        """SIGTERM (SIGKILL after ``timeout_s``); the node's whole output."""
        if self.proc.poll() is None:
            self.proc.terminate()
        try:
            self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.reader.join(timeout=timeout_s)
        while not self.lines.empty():
            line = self.lines.get()
            if line is not None:
                self.output.append(line)
        return "".join(self.output)


def run_command(line: str) -> subprocess.CompletedProcess:
    return subprocess.run(console_script(shlex.split(line)), cwd=ROOT, capture_output=True,
                          text=True, timeout=COMMAND_TIMEOUT_S)


def test_readme_replay_recipe_runs_as_written():
    """Every line of the recipe: `... &` starts a node (waited for by its ready line), the
    others run to completion with exit status 0; the reference bag's 850 DL forces are
    answered exactly as recorded by a node that runs the bag's configuration."""
    recipe = readme_recipe()
    assert [line.endswith("&") for line in recipe] == [True, False]
    assert "bags/reference/case3_stepped.mcap" in recipe[1]
    nodes = []
    try:
        for line in recipe:
            if line.endswith("&"):
                nodes.append(NodeProcess(line[:-1]))
                nodes[-1].wait_ready()
                continue
            proc = run_command(line)
            assert proc.returncode == 0, proc.stdout + proc.stderr
    finally:
        logs = [node.stop() for node in nodes]
    out = proc.stdout
    assert f"configuration: /foot_controller (answering {DL_FORCE}) runs the bag's" in out, out
    assert f"{DL_FORCE}: 850 answers, 850 compared" in out, out
    assert "check (tolerance 1e-12): every answer equals the recording" in out, out
    assert "Traceback" not in proc.stderr + "".join(logs)


@pytest.fixture(scope="module")
def stepped_bag(tmp_path_factory):
    """0.1 s of config/scenario_case3_stepped.yaml (starting at 10 Hz, 5 kHz: 500 samples), as
    `rotor-avc simulate --per-sample` records it."""
    tmp = tmp_path_factory.mktemp("replay_refusal")
    scenario = tmp / "stepped_short.yaml"
    scenario.write_text(f"include: {find_config('scenario_case3_stepped')}\n"
                        "simulation:\n  duration_s: 0.1\n")
    bag = tmp / "stepped.mcap"
    proc = run_command(f"rotor-avc simulate {scenario} --per-sample --out {bag}")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return scenario, bag


def test_a_node_of_another_configuration_is_refused_forced_and_fixed(stepped_bag):
    """A controller of scenario_case3_steady (starting on the steady state at 20 Hz) against a
    bag of scenario_case3_stepped (10 Hz, the same rate and G_c): refused naming
    initial_state.speed_hz with both values; --force replays and fails the check saying why;
    the printed command starts a node that answers every force as recorded."""
    scenario, bag = stepped_bag
    replay = f"rotor-avc replay {bag} --fast --topics {DL_ACC} --check 1e-12"
    node = NodeProcess("foot_controller --ros-args -r __node:=fc_steady_DL "
                       "-p scenario:=scenario_case3_steady -p foot_id:=DL")
    try:
        node.wait_ready()
        refused = run_command(replay)
        forced = run_command(replay + " --force")
    finally:
        log = node.stop()
    assert "Traceback" not in refused.stderr + forced.stderr + log
    command = (f"foot_controller --ros-args -r __node:=fc_steady_DL -p scenario:={scenario} "
               "-p foot_id:=DL")
    assert refused.returncode == 2, refused.stdout + refused.stderr
    assert refused.stdout.splitlines()[1:] == [
        f"refused: /fc_steady_DL answers {DL_FORCE} with another configuration than the bag's, "
        "so its answers would differ from the recorded ones; nothing was published:",
        f"  initial_state.speed_hz: bag 10, node 20 -- fix: {command}, or --force"]
    assert forced.returncode == 1, forced.stdout + forced.stderr
    assert (f"warning (--force): /fc_steady_DL answers {DL_FORCE} with another configuration "
            "than the bag's; replayed anyway:\n  initial_state.speed_hz: bag 10, node 20\n"
            in forced.stdout), forced.stdout
    assert "published 500 messages at 500 log times" in forced.stdout
    diff = float(re.search(r"max \|difference\| (\S+)", forced.stdout).group(1))
    assert diff > 1.0, forced.stdout                      # newtons: another start, other forces
    assert (f"FAIL on {DL_FORCE} (replayed with --force: the configuration differed from the "
            "bag's in /fc_steady_DL: initial_state.speed_hz)") in forced.stdout
    fixed = NodeProcess(command)
    try:
        fixed.wait_ready()
        again = run_command(replay)
    finally:
        fixed.stop()
    assert again.returncode == 0, again.stdout + again.stderr
    assert "every answer equals the recording" in again.stdout


def test_the_query_reads_each_answering_node_and_an_older_one_has_none():
    """In one process: a foot controller (its parameter given on the command line too: ignored),
    the balancer and a node that publishes NL's forces without the parameter; the replay side's
    query gets each one's answer configuration as the node's scenario gives it."""
    from rotor_avc.nodes.balancer import Balancer
    from rotor_avc.nodes.foot_controller import FootController
    from rotor_avc.nodes.replay_config import read_answer_configs
    from rotor_avc.nodes.runtime import make_executor
    topics = [DL_FORCE, "/avc/balancer/command", "/avc/foot/NL/actuator_force"]
    context = rclpy.Context()
    rclpy.init(context=context)
    ex = make_executor("events", context)
    nodes = []
    try:
        nodes = [FootController("fc_query_DL", context=context, parameter_overrides=params(
                     scenario="scenario_case3_steady", foot_id="DL", answer_config="{}")),
                 Balancer("bal_query", context=context,
                          parameter_overrides=params(scenario="scenario_balance_runup")),
                 rclpy.create_node("older_NL", context=context),
                 rclpy.create_node("asker", context=context)]
        nodes[2].create_publisher(WrenchStamped, topics[2], 10)
        for node in nodes:
            ex.add_node(node)
        asker = nodes[3]
        assert spin_until(ex, lambda: all(asker.count_publishers(t) for t in topics), 60)
        got = {c.name: c for c in read_answer_configs(asker, ex, topics, 30.0)}
    finally:
        ex.shutdown()
        for node in nodes:
            node.destroy_node()
        rclpy.shutdown(context=context)
    assert got.keys() == {"/fc_query_DL", "/bal_query", "/older_NL"}
    assert got["/fc_query_DL"].text == answer_config(
        load_scenario("scenario_case3_steady"), "feedback", "DL").to_json()
    assert got["/bal_query"].text == answer_config(
        load_scenario("scenario_balance_runup"), "balancer").to_json()
    assert got["/older_NL"].text is None and got["/older_NL"].unread == ""
