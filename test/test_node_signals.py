"""SIGINT or SIGTERM at any moment of a node's life -- before the interpreter has run a line,
during the imports, while the machine is built, while waiting for discovery, mid-run -- ends
the node with exit status 0 and no traceback, and a recorder's bag is finished and readable."""
import signal
import time

import pytest

from ros_helpers import node_process, stop, wait_for_nodes  # noqa: F401

from rotor_avc.bag import BagReader

pytestmark = pytest.mark.ros

#: seconds after the start: before Python runs, in the imports, building, discovery/waiting
DELAYS_S = (0.0, 0.02, 0.15, 0.6, 1.5)
NODES = {
    "plant_simulator": ["-p", "scenario:=scenario_case3_steady"],
    "foot_controller": ["-p", "scenario:=scenario_case3_steady", "-p", "foot_id:=DL"],
    "recorder": ["-p", "scenario:=scenario_case3_steady"],
}


def start_all(tmp_path, tag):
    procs = {}
    for node, args in NODES.items():
        extra = ["-p", f"path:={tmp_path / f'{tag}.mcap'}"] if node == "recorder" else []
        procs[node] = node_process(node, *args, *extra, "-r", f"__node:={node}_{tag}")
    return procs


def check_clean(procs, sig, when):
    for node, proc in procs.items():
        out = stop(proc, timeout_s=60)
        assert proc.returncode == 0, f"{node}: {signal.Signals(sig).name} {when}: exit " \
                                     f"{proc.returncode}\n{out}"
        assert "Traceback" not in out and "KeyboardInterrupt" not in out, f"{node} {when}: {out}"


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_during_start_up(tmp_path, sig):
    for i, delay in enumerate(DELAYS_S):
        procs = start_all(tmp_path, f"{sig.name}_{i}")
        time.sleep(delay)                    # the moment of the signal, not a readiness wait
        for proc in procs.values():
            proc.send_signal(sig)
        check_clean(procs, sig, f"{delay} s after the start")
        bag = tmp_path / f"{sig.name}_{i}.mcap"
        if bag.exists():                     # the recorder had created it: finished
            with BagReader(bag) as r:
                assert r.counts is not None      # written by close(): the bag was finished


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_once_running(tmp_path, sig):
    procs = start_all(tmp_path, f"run_{sig.name}")
    assert wait_for_nodes([f"{n}_run_{sig.name}" for n in NODES], procs=procs.values())
    for proc in procs.values():
        proc.send_signal(sig)
    check_clean(procs, sig, "once running")
    with BagReader(tmp_path / f"run_{sig.name}.mcap") as r:
        assert r.counts is not None


def test_repeated_signals_while_shutting_down_are_ignored():
    # the first signal asks for a stop; more arriving during the shutdown (a supervisor's
    # terminate on top of the user's Ctrl-C) neither raise nor kill: exit status 0
    import subprocess
    import sys
    code = ("import os, signal\n"
            "from rotor_avc.nodes import signals\n"
            "signals.running()\n"
            "os.kill(os.getpid(), signal.SIGTERM)\n"
            "assert signals.stop_requested()\n"
            "signals.shutting_down()\n"
            "for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGTERM):\n"
            "    os.kill(os.getpid(), sig)\n"
            "print('finished')\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "finished", done.stderr
