"""The node processes' DDS transport stays on loopback: a foot controller started as a user starts
it (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, no profile of their own) binds every UDP socket
to 127.0.0.1 (read from /proc/<pid>/net/udp and /proc/<pid>/fd), keeps the shared-memory
transport, and answers measurements from a participant of this process that runs without the
profile; the same node under a profile without the whitelist binds 0.0.0.0 (what the listing
catches); a user's own profile or another middleware is left alone."""
import os
import socket
import struct

import pytest

from ros_helpers import make_executor, node_process, rclpy, spin_until, stop, wait_for_nodes
from test_ros_graph import scenario_file

from geometry_msgs.msg import AccelStamped, WrenchStamped

from rotor_avc.nodes import messages as m
from rotor_avc.nodes import transport

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module", autouse=True)
def ros():
    rclpy.init()
    yield
    rclpy.shutdown()


def udp_sockets(pid: int) -> list[tuple[str, int]]:
    """``(local address, port)`` of every UDP socket the process holds: its socket inodes from
    /proc/<pid>/fd, their local addresses from /proc/<pid>/net/udp and udp6 (IPv6 as hex)."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:                       # closed meanwhile
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    found = []
    for table in ("udp", "udp6"):
        with open(f"/proc/{pid}/net/{table}") as fh:
            next(fh)
            for line in fh:
                fields = line.split()
                if fields[9] in inodes:
                    address, port = fields[1].split(":")
                    if table == "udp":
                        address = socket.inet_ntoa(struct.pack("<I", int(address, 16)))
                    found.append((address, int(port, 16)))
    return sorted(found)


def shared_memory_segments(pid: int) -> set[str]:
    """Fast DDS shared-memory segments the process has mapped."""
    with open(f"/proc/{pid}/maps") as fh:
        return {line.split()[-1] for line in fh if "/dev/shm/fastrtps_" in line}


def answered_measurements(proc, n: int = 5) -> int:
    """Publish ``n`` DL measurements from this process (no profile) to the node process, one
    after the answer to the one before; the answers received."""
    node = rclpy.create_node("transport_probe")
    answers = []
    node.create_subscription(WrenchStamped, m.actuator_topic("DL", "actuator_force"),
                             answers.append, m.LOCKSTEP_QOS)
    pub = node.create_publisher(AccelStamped, m.actuator_topic("DL", "acceleration"), m.LOCKSTEP_QOS)
    ex = make_executor("events")
    ex.add_node(node)
    try:
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0, timeout_s=60)
        msg = AccelStamped()
        msg.header.frame_id = "foot_DL"
        for k in range(n):
            m.set_stamp(msg.header.stamp, k * 200_000)
            msg.accel.linear.z = 0.1 * k
            pub.publish(msg)
            if not spin_until(ex, lambda: len(answers) > k or proc.poll() is not None,
                              timeout_s=30):
                break
    finally:
        ex.shutdown()
        node.destroy_node()
    return len(answers)


def start_controller(tmp_path, name: str, env_extra=None):
    sc = scenario_file(tmp_path, "foot_mount_case3", 20.0, initial="rest")
    proc = node_process("foot_controller", "-r", f"__node:={name}", "-p", f"scenario:={sc}",
                        "-p", "foot_id:=DL", env_extra=env_extra)
    assert wait_for_nodes([name], procs=[proc]), stop(proc)
    return proc


def test_node_binds_every_udp_socket_to_loopback(tmp_path):
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"        # as users run it
    assert not any(os.environ.get(v) for v in transport.PROFILE_VARIABLES)
    proc = start_controller(tmp_path, "fc_loopback")
    try:
        assert answered_measurements(proc) == 5          # talks with a profile-less peer
        sockets = udp_sockets(proc.pid)
        segments = shared_memory_segments(proc.pid)
    finally:
        log = stop(proc)
    assert "Traceback" not in log, log
    assert len(sockets) >= 3, sockets                    # discovery, user data, a sender
    assert all(address == "127.0.0.1" for address, _ in sockets), sockets
    assert segments, "the shared-memory transport is gone"


def test_a_profile_without_the_whitelist_binds_every_interface(tmp_path):
    """The control: a user's own profile (here: Fast DDS's defaults) is used untouched, and the
    socket listing sees its sockets on 0.0.0.0."""
    own = tmp_path / "own_profile.xml"
    own.write_text('<?xml version="1.0" encoding="UTF-8" ?>\n<profiles xmlns='
                   '"http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"/>\n')
    proc = start_controller(tmp_path, "fc_own_profile",
                            {"FASTRTPS_DEFAULT_PROFILES_FILE": str(own)})
    try:
        sockets = udp_sockets(proc.pid)
    finally:
        stop(proc)
    assert any(address == "0.0.0.0" for address, _ in sockets), sockets


def test_profile_is_installed_only_where_the_user_has_none(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_LOCALHOST_ONLY": "1"}
    assert transport.use_loopback_profile(env) is None
    assert env == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT",
                   "FASTRTPS_DEFAULT_PROFILES_FILE": str(transport.PROFILE)}
    assert transport.PROFILE.is_file() and "127.0.0.1" in transport.PROFILE.read_text()
    env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}
    transport.use_loopback_profile(env)
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"          # the user's, kept
    for own in ({"FASTRTPS_DEFAULT_PROFILES_FILE": "/etc/mine.xml"},
                {"FASTDDS_DEFAULT_PROFILES_FILE": "/etc/mine.xml"}):
        env = {**own, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
        assert transport.use_loopback_profile(env) is None and env == {
            **own, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    (tmp_path / transport.CWD_PROFILE).write_text("<profiles/>")
    env = {}
    transport.use_loopback_profile(env)
    assert env == {}
    env = {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}
    assert "rmw_cyclonedds_cpp" in transport.use_loopback_profile(env)
    assert env == {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}
    (tmp_path / transport.CWD_PROFILE).unlink()
    monkeypatch.setattr(transport, "PROFILE", tmp_path / "gone.xml")      # incomplete install
    env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    assert "gone.xml is missing" in transport.use_loopback_profile(env)
    assert env == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
