"""Counted publishers and the in-process recording taps.

Every publisher of the package's nodes is a :class:`CountedPublisher` (made by
:func:`publisher`): it counts the messages it publishes -- the publishers' side of the bag's
published/recorded accounting, reported by each node on ``/diagnostics`` -- and hands each one,
synchronously, to the *taps* of its topic in this process.

A tap is how a recorder composed into the same process as the nodes it records (one process,
one executor: :mod:`rotor_avc.nodes.graph` with ``composed=True``, like a ROS 2 component
container) receives their messages without DDS. The message a tap gets is the one given to
``publish`` -- the serialised bytes on the lockstep hot path, serialised here otherwise -- at the
moment it is published, so such a recording cannot lose or reorder anything, and it costs a list
append instead of a DDS delivery and an executor callback per message (bench/bench_ros_loop.py:
a recorder subscribed through DDS in the same process halved the loop rate). Messages published
by nodes of other processes reach a recorder only through its subscriptions.

The registry is per process and free of global side effects for processes that never record:
with no tap registered, publishing costs one attribute check more than rclpy's.
"""
from __future__ import annotations

import threading
from typing import Callable

from rclpy.publisher import Publisher
from rclpy.serialization import serialize_message

Tap = Callable[[bytes], None]
#: topic -> the taps of that topic (shared, mutated in place, so publishers see new taps)
_TAPS: dict[str, list[Tap]] = {}
#: the publishers of this process, and who wants to hear about new ones
_PUBLISHERS: list["CountedPublisher"] = []
_WATCHERS: list[Callable[["CountedPublisher"], None]] = []
#: topic -> messages published by counted publishers of this process destroyed since
_RETIRED: dict[str, int] = {}
_LOCK = threading.Lock()


class CountedPublisher(Publisher):
    """An rclpy publisher that counts its messages and feeds this process's taps."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.count = 0
        self.topic_resolved = self.topic_name
        self.type_name = _type_name(self.msg_type)
        with _LOCK:
            self._taps = _TAPS.setdefault(self.topic_resolved, [])
            _PUBLISHERS.append(self)
            watchers = list(_WATCHERS)
        for watch in watchers:
            watch(self)

    def publish(self, msg) -> None:
        super().publish(msg)
        self.count += 1
        if self._taps:
            data = msg if isinstance(msg, bytes) else serialize_message(msg)
            for tap in self._taps:
                tap(data)

    def destroy(self) -> None:
        with _LOCK:
            if self in _PUBLISHERS:
                _PUBLISHERS.remove(self)
                _RETIRED[self.topic_resolved] = _RETIRED.get(self.topic_resolved, 0) + self.count
        super().destroy()


def publisher(node, msg_type, topic: str, qos) -> CountedPublisher:
    """``node.create_publisher`` with a :class:`CountedPublisher`."""
    return node.create_publisher(msg_type, topic, qos, publisher_class=CountedPublisher)


def published_counts(node) -> dict[str, int]:
    """Messages published per topic by ``node``'s counted publishers."""
    counts: dict[str, int] = {}
    for pub in node.publishers:
        if isinstance(pub, CountedPublisher):
            counts[pub.topic_resolved] = counts.get(pub.topic_resolved, 0) + pub.count
    return counts


def process_counts() -> dict[str, int]:
    """Messages published per topic by the counted publishers of this process, those destroyed
    meanwhile included."""
    with _LOCK:
        counts = dict(_RETIRED)
        for pub in _PUBLISHERS:
            counts[pub.topic_resolved] = counts.get(pub.topic_resolved, 0) + pub.count
    return counts


def watch_publishers(callback: Callable[[CountedPublisher], None]) -> Callable[[], None]:
    """Call ``callback`` for every counted publisher of this process, existing and future;
    returns the function that stops watching."""
    with _LOCK:
        existing = list(_PUBLISHERS)
        _WATCHERS.append(callback)
    for pub in existing:
        callback(pub)

    def unwatch() -> None:
        with _LOCK:
            if callback in _WATCHERS:
                _WATCHERS.remove(callback)
    return unwatch


def add_tap(topic: str, tap: Tap) -> Callable[[], None]:
    """Hand every message published on ``topic`` in this process to ``tap``; returns the
    function that removes it."""
    with _LOCK:
        taps = _TAPS.setdefault(topic, [])
        taps.append(tap)

    def remove() -> None:
        with _LOCK:
            if tap in taps:
                taps.remove(tap)
    return remove


def local_publishers(topic: str) -> int:
    """Counted publishers of ``topic`` in this process."""
    with _LOCK:
        return sum(1 for p in _PUBLISHERS if p.topic_resolved == topic)


def tapped(topic: str) -> bool:
    """Whether a tap records ``topic`` in this process."""
    return bool(_TAPS.get(topic))


def _type_name(msg_type) -> str:
    """``geometry_msgs/msg/AccelStamped`` of a message class."""
    module = msg_type.__module__.split(".")[0]
    return f"{module}/msg/{msg_type.__name__}"
