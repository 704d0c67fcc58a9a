"""Benchmark: the ROS lockstep graph with and without the recorder, and real-time mode.

Every figure is measured in this run (the machine may be shared: each lockstep figure is the
best of ``--repeats`` runs, the graphs measured in turn so that load hits them alike):

**Lockstep** -- Werner 2021, case 3 (plant + 3 foot controllers), 5 kHz, constant 20 Hz:

* **ping-pong** -- two nodes in one process, publish -> callback -> publish back (typed
  messages), round trips per second, and the same between two processes (raw bytes): the most a
  lockstep sample could cost is one round trip;
* **loop** -- plant + 3 controllers in one process and executor (rotor_avc.nodes.composed
  without the recorder): samples per second;
* **loop + recorder** -- the same with the recorder composed in (``source: process``: it takes
  the messages from the nodes' publishers) and the plant in the recorder handshake
  (``wait_for_recorder``); the goal is >= 5000 samples/s (real time at 5 kHz) and >= 75 % of the
  loop (the recorder costs at most 25 %);
* **loop + recorder + balancer** -- with the one-plane balancer (config/balancer_foot_mount.yaml)
  answering every sample too;
* **loop + DDS recorder** -- the recorder subscribed through DDS in the same process (each
  message one more DDS delivery and executor callback: why the composed graph taps instead);
* **processes + recorder** -- each node its own process (rotor_avc.nodes.graph, the ``ros2 run``
  layout), against two floors measured in the same run: the 2-process ping-pong and the
  **transport floor of the processes layout** -- the layout's message pattern alone (per sample
  six raw messages of the plant's types and sizes from one process to three answering processes
  and a recording one, which do nothing else; then the three answers), with and without the
  recording process. Each sample wakes five processes on this 2-core machine, so that floor is a
  fraction of one ping-pong; the nodes' own Python is what lies between it and the layout.

**Real time** -- ``mode: realtime`` at 1, 2 and 5 kHz, composed graph with the recorder, 2 s per
rate: the mean period against the nominal one (absolute schedule: no drift), the lateness of
the samples (p50/p99/max), overruns (samples more than a period late) per 10,000 samples, the
messages lost per topic (published - recorded, from the bag), and whether the plant's rate
check refused the rate.

Run: ``python bench/bench_ros_loop.py [--steps 10000] [--repeats 3] [--profile]``
(``--profile``: the hottest functions of one loop + recorder run, cProfile). ROS traffic stays in
this process's private domain on loopback.
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(150 + os.getpid() % 80))

import argparse  # noqa: E402
import cProfile  # noqa: E402
import io  # noqa: E402
import pstats  # noqa: E402
import re  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import rclpy  # noqa: E402
from geometry_msgs.msg import AccelStamped, WrenchStamped  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402

from rotor_avc.bag import BagReader  # noqa: E402
from rotor_avc.config import find_config  # noqa: E402
from rotor_avc.nodes import messages as m  # noqa: E402
from rotor_avc.nodes.composed import build_nodes  # noqa: E402
from rotor_avc.nodes.foot_controller import FootController  # noqa: E402
from rotor_avc.nodes.graph import run_graph  # noqa: E402
from rotor_avc.nodes.plant_simulator import PlantSimulator  # noqa: E402
from rotor_avc.nodes.recorder import Recorder  # noqa: E402
from rotor_avc.nodes.runtime import make_executor  # noqa: E402

FEET = ("DL", "DR", "NL")
REALTIME_HZ = (1000.0, 2000.0, 5000.0)


def scenario(folder: Path, steps: int, balancer: bool = False, rate_hz: float = 5000.0) -> str:
    """Case 3 at a constant 20 Hz, ``steps`` samples at ``rate_hz`` (+ the balancer of
    balancer_foot_mount.yaml, which carries case 3's machine with the balancer plane)."""
    includes = [str(find_config("foot_mount_case3"))]
    if balancer:
        includes.insert(0, str(find_config("balancer_foot_mount")))
    path = folder / f"bench_{'balancer' if balancer else 'case3'}_{rate_hz:g}_{steps}.yaml"
    path.write_text(f"""include: [{', '.join(includes)}]
simulation:
  sample_rate_hz: {rate_hz}
  duration_s: {steps / rate_hz}
  speed: {{type: constant, speed_hz: 20.0}}
  unbalance:
    static: {{magnitude: 1.0e-2, phase_deg: 0.0}}
    moment: {{magnitude: 2.0e-3, phase_deg: 90.0}}
  initial_state: {'rest' if balancer else 'steady_state'}
  balancer: {str(balancer).lower()}
""")
    return str(path)


def params(**values):
    return [Parameter(k, value=v) for k, v in values.items()]


def ping_pong(rounds: int) -> float:
    """Round trips per second in one process: AccelStamped out, WrenchStamped back."""
    ping, pong = rclpy.create_node("bench_ping"), rclpy.create_node("bench_pong")
    out = ping.create_publisher(AccelStamped, "/bench/ping", m.LOCKSTEP_QOS)
    back = pong.create_publisher(WrenchStamped, "/bench/pong", m.LOCKSTEP_QOS)
    measurement, force = AccelStamped(), WrenchStamped()
    state = {"n": 0}

    def on_ping(msg):
        force.header.stamp = msg.header.stamp
        back.publish(force)

    def on_pong(msg):
        state["n"] += 1
        if state["n"] < rounds:
            measurement.header.stamp.nanosec = state["n"]
            out.publish(measurement)

    pong.create_subscription(AccelStamped, "/bench/ping", on_ping, m.LOCKSTEP_QOS)
    ping.create_subscription(WrenchStamped, "/bench/pong", on_pong, m.LOCKSTEP_QOS)
    ex = make_executor("events")
    ex.add_node(ping)
    ex.add_node(pong)
    try:
        return round_trips(ex, out, lambda: back.get_subscription_count() > 0,
                           lambda: out.publish(measurement), state, rounds)
    finally:
        ex.shutdown()
        ping.destroy_node()
        pong.destroy_node()


def round_trips(ex, out, answering, first, state, rounds) -> float:
    """Wait until ``out`` is matched and the answer is ``answering()``, send ``first()``; round
    trips per second until ``state["n"]`` reaches ``rounds``."""
    t_end = time.monotonic() + 60
    while (out.get_subscription_count() < 1 or not answering()) and time.monotonic() < t_end:
        ex.spin_once(timeout_sec=0.05)
    for _ in range(20):                           # let the match settle on both sides
        ex.spin_once(timeout_sec=0.01)
    t0 = time.perf_counter()
    first()
    while state["n"] < rounds and time.monotonic() < t_end + 120:
        ex.spin_once(timeout_sec=0.1)
    return state["n"] / (time.perf_counter() - t0)


PONG = """
import rclpy, sys
from geometry_msgs.msg import AccelStamped, WrenchStamped
from rclpy.serialization import serialize_message
from rotor_avc.nodes import messages as m
from rotor_avc.nodes.runtime import make_executor
rclpy.init()
node = rclpy.create_node("bench_pong_process")
back = node.create_publisher(WrenchStamped, "/bench/xpong", m.LOCKSTEP_QOS)
data = serialize_message(WrenchStamped())
node.create_subscription(AccelStamped, "/bench/xping", lambda d: back.publish(data),
                         m.LOCKSTEP_QOS, raw=True)
ex = make_executor("events")
ex.add_node(node)
while sys.stdin.readable() and rclpy.ok():
    ex.spin_once(timeout_sec=0.1)
"""


def ping_pong_processes(rounds: int) -> float:
    """Round trips per second between two processes (raw bytes both ways)."""
    from rclpy.serialization import serialize_message
    proc = subprocess.Popen([sys.executable, "-c", PONG], stdin=subprocess.PIPE)
    node = rclpy.create_node("bench_ping_process")
    out = node.create_publisher(AccelStamped, "/bench/xping", m.LOCKSTEP_QOS)
    data = serialize_message(AccelStamped())
    state = {"n": 0}

    def on_pong(_):
        state["n"] += 1
        if state["n"] < rounds:
            out.publish(data)

    node.create_subscription(WrenchStamped, "/bench/xpong", on_pong, m.LOCKSTEP_QOS, raw=True)
    ex = make_executor("events")
    ex.add_node(node)
    try:
        return round_trips(ex, out, lambda: node.count_publishers("/bench/xpong") > 0,
                           lambda: out.publish(data), state, rounds)
    finally:
        ex.shutdown()
        node.destroy_node()
        proc.kill()
        proc.wait()


FAN = """
import rclpy, sys
from geometry_msgs.msg import AccelStamped, WrenchStamped
from rclpy.serialization import serialize_message
from rotor_avc.nodes import messages as m
from rotor_avc.nodes.runtime import make_executor
rclpy.init()
role = sys.argv[1]
node = rclpy.create_node("bench_fan_" + role)
if role == "sink":                      # a recorder that only takes: every topic, raw
    for name, kind in TOPICS:
        node.create_subscription(kind, "/bench/fan/" + name, lambda d: None, m.LOCKSTEP_QOS,
                                 raw=True)
else:                                   # a controller: one answer per measurement
    back = node.create_publisher(WrenchStamped, "/bench/fan/force_" + role, m.LOCKSTEP_QOS)
    data = serialize_message(WrenchStamped())
    node.create_subscription(AccelStamped, "/bench/fan/foot_" + role,
                             lambda d: back.publish(data), m.LOCKSTEP_QOS, raw=True)
ex = make_executor("events")
ex.add_node(node)
while sys.stdin.readable() and rclpy.ok():
    ex.spin_once(timeout_sec=0.1)
"""


def fan_topics():
    """The processes layout's message pattern per sample: the plant's six messages (three foot
    measurements, joint state, clock, observables) and the three controllers' answers."""
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray
    return ([(f"foot_{f}", AccelStamped) for f in FEET]
            + [("joint", JointState), ("clock", Clock), ("observables", Float64MultiArray)]
            + [(f"force_{f}", WrenchStamped) for f in FEET])


def fan_floor(rounds: int, recorder: bool = True) -> float:
    """Samples per second of the processes layout's transport alone: this process publishes
    each sample's six messages (raw, the plant's sizes) to three answering processes and a
    recording one (``recorder``; raw subscriptions, no work) and waits for the three answers --
    the floor of the layout's message pattern on this machine, without the nodes' Python."""
    from rclpy.serialization import serialize_message
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray
    topics = fan_topics()
    script = ("from rosgraph_msgs.msg import Clock\nfrom sensor_msgs.msg import JointState\n"
              "from std_msgs.msg import Float64MultiArray\n"
              "from geometry_msgs.msg import AccelStamped, WrenchStamped\n"
              f"TOPICS = [{', '.join(f'({n!r}, {k.__name__})' for n, k in topics)}]\n" + FAN)
    procs = [subprocess.Popen([sys.executable, "-c", script, role], stdin=subprocess.PIPE)
             for role in (*FEET, "sink")[:len(FEET) + recorder]]
    node = rclpy.create_node("bench_fan_plant")
    joint = JointState(name=["rotor"], position=[0.0], velocity=[0.0])
    obs = Float64MultiArray(data=[0.0] * 31)
    payload = {"joint": joint, "clock": Clock(), "observables": obs}
    pubs = [(node.create_publisher(kind, "/bench/fan/" + name, m.LOCKSTEP_QOS),
             serialize_message(payload.get(name, kind())))
            for name, kind in topics[:6]]
    state = {"n": 0, "answers": 0}

    def on_answer(_):
        state["answers"] += 1
        if state["answers"] == len(FEET):
            state["answers"] = 0
            state["n"] += 1
            if state["n"] < rounds:
                send()

    def send():
        for pub, data in pubs:
            pub.publish(data)

    for f in FEET:
        node.create_subscription(WrenchStamped, f"/bench/fan/force_{f}", on_answer,
                                 m.LOCKSTEP_QOS, raw=True)
    ex = make_executor("events")
    ex.add_node(node)
    try:
        return round_trips(ex, pubs[0][0], lambda: all(
            node.count_publishers(f"/bench/fan/force_{f}") > 0 for f in FEET) and all(
            p.get_subscription_count() >= recorder for p, _ in pubs), send, state, rounds)
    finally:
        ex.shutdown()
        node.destroy_node()
        for proc in procs:
            proc.kill()
            proc.wait()


def run_in_process(nodes, plant, profile: bool = False) -> float:
    """Spin ``nodes`` in one events executor until the plant's run is complete; samples/s."""
    ex = make_executor("events")
    for n in nodes:
        ex.add_node(n)
    prof = cProfile.Profile() if profile else None
    try:
        t_end = time.monotonic() + 300
        while not plant.started and time.monotonic() < t_end:
            ex.spin_once(timeout_sec=0.05)
        if prof:
            prof.enable()
        while not plant.finished and time.monotonic() < t_end:
            ex.spin_once(timeout_sec=0.1)
        if prof:
            prof.disable()
        for n in nodes:
            if hasattr(n, "drain"):
                n.drain(ex)
        if plant.fault_log or plant.book.resends or plant.exit_status:
            raise RuntimeError(f"the benchmark run had faults: {plant.fault_log}, "
                               f"{plant.book.resends} resends")
        return plant.n_steps / plant.wall_s
    finally:
        ex.shutdown()
        for n in nodes:
            if hasattr(n, "close"):
                n.close()
            n.destroy_node()
        if prof:
            text = io.StringIO()
            pstats.Stats(prof, stream=text).sort_stats("tottime").print_stats(15)
            print(text.getvalue())


def loop(sc: str) -> float:
    plant = PlantSimulator("bench_plant", parameter_overrides=params(scenario=sc))
    ctrls = [FootController(f"bench_fc_{f}", parameter_overrides=params(scenario=sc, foot_id=f))
             for f in FEET]
    return run_in_process([plant, *ctrls], plant)


def loop_recorded(sc: str, bag: Path, profile: bool = False) -> float:
    nodes = []
    build_nodes(sc, str(bag), nodes)
    return run_in_process(nodes, nodes[-1], profile)


def loop_dds_recorder(sc: str, bag: Path) -> float:
    rec = Recorder("bench_recorder", parameter_overrides=params(scenario=sc, path=str(bag)))
    plant = PlantSimulator("bench_plant", parameter_overrides=params(
        scenario=sc, wait_for_recorder="bench_recorder"))
    ctrls = [FootController(f"bench_fc_{f}", parameter_overrides=params(scenario=sc, foot_id=f))
             for f in FEET]
    return run_in_process([rec, plant, *ctrls], plant)


def processes(sc: str, bag: Path, logs: Path) -> float:
    run = run_graph(sc, bag, logs)
    return _plant_rate(run.logs["plant_simulator"])


def _plant_rate(log: str) -> float:
    return float(re.search(r"\(([0-9.]+) samples/s\)", log).group(1))


def realtime(folder: Path, rate_hz: float) -> dict:
    """One composed real-time run of 2 s at ``rate_hz`` with the recorder."""
    sc = scenario(folder, int(2 * rate_hz), rate_hz=rate_hz)
    bag = folder / f"realtime_{rate_hz:g}.mcap"
    try:
        run = run_graph(sc, bag, folder / "logs", layout="composed",
                        plant_params={"mode": "realtime", "realtime_overload": "warn"})
    except Exception as exc:                     # reported in the table, not hidden
        return {"error": str(exc).splitlines()[0][:120]}
    log = run.logs["composed"]
    row = {"held": "not held" not in log}
    found = re.search(r"mean period ([0-9.]+) us \(([-+0-9.]+) %\), lateness p50 (\d+) / p99 "
                      r"(\d+) / max (\d+) us, \d+ overruns \((\d+) per 10,000", log)
    if found:
        row.update(zip(("period_us", "error_pct", "p50", "p99", "max", "over"), found.groups()))
    with BagReader(bag) as r:
        counts = r.counts or {}
    row["lost"] = {t: c["published"] - c["recorded"] for t, c in counts.items()
                   if c["published"] is not None and c["published"] > c["recorded"]}
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=10000, help="lockstep samples per run")
    ap.add_argument("--repeats", type=int, default=3, help="best of this many runs per figure")
    ap.add_argument("--profile", action="store_true", help="profile one loop + recorder run")
    args = ap.parse_args()
    rclpy.init()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            sc, sc_bal = scenario(folder, args.steps), scenario(folder, args.steps, True)
            graphs = {
                "ping-pong (1 process)": lambda i: ping_pong(args.steps),
                "ping-pong (2 processes)": lambda i: ping_pong_processes(args.steps),
                "transport floor of the processes layout": lambda i: fan_floor(args.steps),
                "transport floor without the recorder": lambda i: fan_floor(args.steps, False),
                "loop": lambda i: loop(sc),
                "loop + recorder": lambda i: loop_recorded(sc, folder / f"r{i}.mcap",
                                                           args.profile and i == 0),
                "loop + recorder + balancer": lambda i: loop_recorded(
                    sc_bal, folder / f"b{i}.mcap"),
                "loop + DDS recorder": lambda i: loop_dds_recorder(sc, folder / f"d{i}.mcap"),
                "processes + recorder": lambda i: processes(sc, folder / f"p{i}.mcap",
                                                            folder / f"logs{i}"),
            }
            best = {name: 0.0 for name in graphs}
            for i in range(args.repeats):
                for name, run in graphs.items():
                    best[name] = max(best[name], run(i))
            base = best["loop"]
            print(f"lockstep, Werner 2021 case 3, 5 kHz, {args.steps} samples, best of "
                  f"{args.repeats}")
            print(f"{'graph':30s} {'per s':>9s} {'vs loop':>8s}")
            for name, rate in best.items():
                print(f"{name:30s} {rate:9.0f} {rate / base:8.0%}")
            proc, floor = best["processes + recorder"], best["transport floor of the processes layout"]
            print(f"processes + recorder: {proc / best['ping-pong (2 processes)']:.2f} of the "
                  f"2-process ping-pong, {proc / floor:.2f} of its layout's transport floor "
                  f"(the floor itself {floor / best['ping-pong (2 processes)']:.2f} of the "
                  "ping-pong)")
            rec = best["loop + recorder"]
            print(f"goal: loop + recorder >= 5000 samples/s ({rec:.0f}) and >= 75 % of the loop "
                  f"({rec / base:.0%})")
            print("\nreal time (mode: realtime), composed graph with the recorder, 2 s per rate")
            print(f"{'rate':>7s} {'mean period':>14s} {'error':>9s} {'late p50':>9s} "
                  f"{'p99':>7s} {'max':>7s} {'overruns/10k':>13s}  lost per topic")
            for rate_hz in REALTIME_HZ:
                row = realtime(folder, rate_hz)
                if "error" in row:
                    print(f"{rate_hz:7.0f} {row['error']}")
                    continue
                lost = ", ".join(f"{t} {n}" for t, n in row["lost"].items()) or "none"
                print(f"{rate_hz:7.0f} {row.get('period_us', '?'):>11s} us "
                      f"{row.get('error_pct', '?'):>7s} % {row.get('p50', '?'):>6s} us "
                      f"{row.get('p99', '?'):>4s} us {row.get('max', '?'):>4s} us "
                      f"{row.get('over', '?'):>13s}  {lost}"
                      + ("" if row["held"] else "   (rate check: not held)"), flush=True)
    finally:
        rclpy.shutdown()


if __name__ == "__main__":
    main()
