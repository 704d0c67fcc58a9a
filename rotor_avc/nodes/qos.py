"""The QoS profiles of the package's topics (lockstep traffic, sensor inputs, diagnostics), and
a topic's offered QoS in the form a bag records it."""
from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..bag.errors import BagError
from ..bag.metadata import qos_profiles

#: history of the lockstep publishers: deeper than any recorder window (the plant's
#: ``recorder_window`` is at most LOCKSTEP_DEPTH - RECORDER_MARGIN), so a writer never overwrites
#: a message that a recording reader has not taken yet
LOCKSTEP_DEPTH = 4096
RECORDER_MARGIN = 96
#: lockstep traffic: reliable, KEEP_LAST LOCKSTEP_DEPTH, transient-local: a reader gets what was
#: published before it matched (discovery is asynchronous, so a subscription can exist before
#: the publisher delivers to it). The package's own lockstep readers (plant, controllers,
#: balancer, harmonic controller) ask for it; such a reader matches only reliable,
#: transient-local publishers
LOCKSTEP_QOS = QoSProfile(depth=LOCKSTEP_DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                          history=HistoryPolicy.KEEP_LAST,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: a sensor driver's input: the reliability and durability of rclpy's ``qos_profile_sensor_data``
#: (best effort, volatile), which match every publisher -- best effort or reliable, volatile or
#: transient-local -- with the lockstep depth (the newest LOCKSTEP_DEPTH messages kept)
SENSOR_QOS = QoSProfile(depth=LOCKSTEP_DEPTH, reliability=ReliabilityPolicy.BEST_EFFORT,
                        history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
#: reliable delivery without asking for history: matches reliable publishers of either
#: durability (not best-effort ones)
RELIABLE_QOS = QoSProfile(depth=LOCKSTEP_DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                          history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
#: the QoS a measurement subscription may take (rotor_avc.nodes.foot_controller)
MEASUREMENT_QOS = {"sensor_data": SENSOR_QOS, "reliable": RELIABLE_QOS, "lockstep": LOCKSTEP_QOS}
#: /diagnostics of the package's nodes: reliable, the last 10 kept for a late-joining recorder
DIAGNOSTICS_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                             history=HistoryPolicy.KEEP_LAST,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)


def offered_qos(node, name: str) -> list[dict] | None:
    """The QoS of the topic's publishers (as ``node`` sees them) in the bag's form (None: the
    default profile)."""
    profiles = []
    for info in node.get_publishers_info_by_topic(name):
        q = info.qos_profile
        profiles.append({
            "history": q.history.name.lower(), "depth": q.depth,
            "reliability": q.reliability.name.lower(), "durability": q.durability.name.lower(),
            "deadline": _duration(q.deadline), "lifespan": _duration(q.lifespan),
            "liveliness": q.liveliness.name.lower(),
            "liveliness_lease_duration": _duration(q.liveliness_lease_duration),
            "avoid_ros_namespace_conventions": q.avoid_ros_namespace_conventions})
    try:
        return qos_profiles(profiles) if profiles else None
    except BagError as exc:
        node.get_logger().warning(f"{name}: offered QoS not recordable ({exc}); "
                                  "recording the default profile")
        return None


def _duration(d) -> dict:
    sec, nsec = divmod(d.nanoseconds, 1_000_000_000)
    return {"sec": sec, "nsec": nsec}
