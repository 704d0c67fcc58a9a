"""The floors of the lockstep graphs (bench_ros_loop.py): what the transport alone allows.

* **ping-pong** -- two nodes, publish -> callback -> publish back, in one process (typed
  messages) and between two processes (raw bytes): one lockstep sample needs at least one such
  round trip;
* **the transport floor of the processes layout** (:func:`fan_floor`) -- the layout's message
  pattern with no node work: per sample this process publishes the plant's six messages (its
  types and sizes, raw) to three answering processes and a recording one, and waits for the
  three answers.

Each returns its rate and the CPU of every process taking part (ros_profile.CpuSpan).
"""
import subprocess
import sys
import time

import rclpy
from geometry_msgs.msg import AccelStamped, WrenchStamped

from ros_profile import CpuSpan

from rotor_avc.nodes import messages as m
from rotor_avc.nodes.runtime import make_executor

FEET = ("DL", "DR", "NL")
#: one graph's figure: samples (round trips) per second and the CPU per sample of its processes
Arm = tuple[float, CpuSpan]


def ping_pong(rounds: int) -> Arm:
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


def round_trips(ex, out, answering, first, state, rounds) -> tuple[float, CpuSpan]:
    """Wait until ``out`` is matched and the answer is ``answering()``, send ``first()``; round
    trips per second until ``state["n"]`` reaches ``rounds``, and the CPU of this process and
    its children meanwhile."""
    t_end = time.monotonic() + 60
    while (out.get_subscription_count() < 1 or not answering()) and time.monotonic() < t_end:
        ex.spin_once(timeout_sec=0.05)
    for _ in range(20):                           # let the match settle on both sides
        ex.spin_once(timeout_sec=0.01)
    cpu = CpuSpan()
    cpu.begin()
    t0 = time.perf_counter()
    first()
    while state["n"] < rounds and time.monotonic() < t_end + 120:
        ex.spin_once(timeout_sec=0.1)
    rate = state["n"] / (time.perf_counter() - t0)
    cpu.end(state["n"])
    return rate, cpu


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


def ping_pong_processes(rounds: int) -> Arm:
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


def fan_floor(rounds: int, recorder: bool = True) -> Arm:
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


def fan_traced_topics():
    """The transport floor's topics as :func:`graph_topics` (same roles, same order)."""
    return [("/bench/fan/" + name, kind) for name, kind in fan_topics()
            if name not in ("joint", "clock")]
