"""The DDS transport of the package's node processes: every UDP socket on loopback.

``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` alone does not keep a node off the network with
rmw_fastrtps (ROS 2 Jazzy, Fast DDS 2.14 from PyPI): it limits *discovery* to this host (initial
peer 127.0.0.1, no multicast), but rmw adds a UDPv4 transport of its own without an interface
whitelist, so the participant binds its receiving ports to 0.0.0.0 and a sending socket to every
interface's address (measured: ``ss -uanp`` of a running node). The Fast DDS profile shipped
beside this module (:data:`PROFILE`, package data) binds every UDP socket to 127.0.0.1:

* a UDPv4 transport whitelisted to 127.0.0.1 and the shared-memory transport (messages between
  processes of this host take shared memory as before), Fast DDS's built-in transports off;
* discovery by unicast on 127.0.0.1 only: a metatraffic unicast locator 127.0.0.1 (so no
  multicast locator, no socket on 239.255.0.1) and the initial peers 127.0.0.1 (participants
  0..31 of the domain, rmw's LOCALHOST number).

Such a node discovers and talks with every other participant of the domain on this host, also
ones run with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and no profile (``ros2`` tools, tests).

:func:`use_loopback_profile` installs it in a node process's environment before rclpy starts
(:func:`rotor_avc.nodes.runtime.run_node`, :mod:`rotor_avc.nodes.composed`): it sets
``FASTRTPS_DEFAULT_PROFILES_FILE`` (the variable Fast DDS 2.x reads) unless the user has a profile
of their own (``FASTRTPS_DEFAULT_PROFILES_FILE``, ``FASTDDS_DEFAULT_PROFILES_FILE``, or a
``DEFAULT_FASTRTPS_PROFILES.xml`` in the working directory: theirs is used, untouched) or runs
another middleware (``RMW_IMPLEMENTATION``). With the profile, a discovery range of
``LOCALHOST`` (or ``ROS_LOCALHOST_ONLY=1``) would make rmw add its unrestricted transport again,
so it becomes ``SYSTEM_DEFAULT`` (as does an unset range; ``ROS_LOCALHOST_ONLY`` is dropped): the
profile alone decides, and it discovers this host only. ``SUBNET`` and ``OFF`` set by the user
stay (the sockets are on loopback either way).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

#: the Fast DDS profile of the package's node processes
PROFILE = Path(__file__).with_name("fastdds_loopback.xml")
PROFILE_VARIABLES = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")
#: the profile Fast DDS loads from the working directory when no variable names one
CWD_PROFILE = "DEFAULT_FASTRTPS_PROFILES.xml"
FAST_DDS_RMWS = ("rmw_fastrtps_cpp", "rmw_fastrtps_dynamic_cpp")


def use_loopback_profile(environ=os.environ) -> str | None:
    """Install :data:`PROFILE` in ``environ`` (see the module docstring) before rclpy starts
    the process's first participant. When another middleware runs or the profile is missing,
    the transport is not restricted: that is said on stderr and returned (None otherwise, also
    when the user's own profile is used: their choice)."""
    rmw = environ.get("RMW_IMPLEMENTATION", "")
    if rmw and rmw not in FAST_DDS_RMWS:
        note = (f"RMW_IMPLEMENTATION={rmw}: the shipped loopback profile is Fast DDS's; this "
                "node's sockets are bound as that middleware binds them")
        print(f"warning: {note}", file=sys.stderr)
        return note
    if any(environ.get(name) for name in PROFILE_VARIABLES) or Path(CWD_PROFILE).is_file():
        return None
    if not PROFILE.is_file():
        note = (f"{PROFILE} is missing (an incomplete install): this node's sockets are bound "
                "as Fast DDS binds them by default -- fix: reinstall rotor_avc")
        print(f"warning: {note}", file=sys.stderr)
        return note
    environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(PROFILE)
    if environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "") in ("", "LOCALHOST"):
        environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"
    environ.pop("ROS_LOCALHOST_ONLY", None)       # "1" would be rmw's LOCALHOST range again
    return None
