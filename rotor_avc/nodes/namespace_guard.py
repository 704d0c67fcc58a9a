"""One plant and one recorder per namespace: who else publishes a node's own topics.

Two plants on one namespace feed the controllers two sample streams (whose answers then fit
neither run), and two recorders both claim the run; neither may start. A node asks the ROS graph
(``get_publishers_info_by_topic``) which nodes besides itself publish topics only it should
publish -- a plant its sampled topics, a recorder its ``recorder/progress`` -- and refuses to
start when there are any (:class:`NamespaceGuard`: one line in the log, exit status
:data:`EXIT_NAMESPACE_TAKEN`). Discovery is asynchronous, so the nodes ask on every tick of their
start-up, not once, and start only after the graph has held still for
:data:`DISCOVERY_SETTLE_S`.
"""
from __future__ import annotations

import time

from rclpy.node import Node

#: exit status of a plant or recorder refused because its namespace is taken
EXIT_NAMESPACE_TAKEN = 6
#: wall time the graph must hold still (a plant's responders all seen, a recorder's namespace
#: topics first seen) before a plant publishes sample 0 or a recorder subscribes: discovery is
#: asynchronous, and another plant or recorder must be seen before this one starts
DISCOVERY_SETTLE_S = 0.5


#: what rmw reports for a node whose name has not been discovered yet
_UNKNOWN = "_NODE_NAME_UNKNOWN_"


class GraphStillness:
    """Whether what discovery shows of a namespace (any comparable summary of its endpoints)
    has stayed the same for :data:`DISCOVERY_SETTLE_S` (discovery trickles in slowly on a
    loaded host: a fixed wait from the first sight would start too early there)."""

    def __init__(self):
        self.seen, self.since = None, None

    def held(self, seen, now: float) -> bool:
        if seen != self.seen:
            self.seen, self.since = seen, now
        return now - self.since >= DISCOVERY_SETTLE_S

    def reset(self) -> None:
        self.seen = self.since = None


def other_publishers(node: Node, topics, own: int = 1) -> list[str]:
    """Nodes (``namespace/name``) publishing any of ``topics`` besides ``node``'s ``own``
    publishers of each (a node whose name is not discovered yet contains ``_UNKNOWN``)."""
    me = (node.get_namespace().rstrip("/"), node.get_name())
    out = set()
    for topic in topics:
        infos = node.get_publishers_info_by_topic(topic)
        if len(infos) <= own:
            continue
        names = [(i.node_namespace.rstrip("/"), i.node_name) for i in infos]
        for _ in range(own):                     # this node's own publishers
            if me in names:
                names.remove(me)
        out |= {f"{ns}/{name}" for ns, name in names[:len(infos) - own]}
    return sorted(out)


class NamespaceGuard:
    """Start-up check of one node: is another node publishing ``topics`` (see the module
    docstring)? ``what`` says what that node does, for the refusal line."""

    def __init__(self, node: Node, what: str, namespace: str):
        self.node, self.what, self.namespace = node, what, namespace
        self.first_seen_s = None
        self.refusal = ""                        # the refusal line, once refused

    def taken(self, topics) -> bool:
        """True while another node publishes ``topics``: this node must not start. It is
        refused (:attr:`refusal`, one error line, exit status :data:`EXIT_NAMESPACE_TAKEN`)
        once the other node's name is known, or DISCOVERY_SETTLE_S after it was first seen."""
        if self.refusal:
            return True
        others = other_publishers(self.node, topics)
        if not others:
            self.first_seen_s = None
            return False
        now = time.monotonic()
        self.first_seen_s = self.first_seen_s or now
        if any(_UNKNOWN in o for o in others) and now - self.first_seen_s < DISCOVERY_SETTLE_S:
            return True                          # named in a moment
        self.refuse(", ".join(others))
        return True

    def refuse(self, who: str) -> None:
        """Refuse to start because ``who`` already does what this node would do."""
        self.refusal = (f"not starting: {who} already {self.what} on namespace "
                        f"{self.namespace!r} (exit status {EXIT_NAMESPACE_TAKEN}) -- fix: one "
                        "plant and one recorder per namespace; stop the other run or give this "
                        "one its own namespace (parameter namespace) or ROS_DOMAIN_ID")
        self.node.get_logger().error(self.refusal)
        self.node.exit_status = EXIT_NAMESPACE_TAKEN
        self.node.exit_requested = True
