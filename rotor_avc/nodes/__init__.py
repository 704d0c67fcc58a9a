"""The ROS 2 nodes (the only package that imports rclpy).

A node started as a process installs its SIGINT/SIGTERM handlers here, before any heavy import
(rotor_avc.nodes.signals)."""
from . import signals as _signals

if _signals.started_as_node():
    _signals.install()
