"""What a bag says about itself: QoS channel metadata, the rosbag2 record, the run configuration.

* ``offered_qos_profiles`` (channel metadata): YAML of a list of QoS profiles in rosbag2's
  version-9 form (``history: keep_last``, ``reliability: reliable``, durations as
  ``{sec, nsec}``), as ``rosbag2_storage::serialize_rclcpp_qos_vector`` writes it.
* The ``rosbag2`` metadata record (key ``serialized_metadata``): the bag's ``metadata.yaml``
  content (version 9), written on close like rosbag2's MCAP plugin does, so ``ros2 bag info``
  reads QoS strings as version 9.
* The ``rotor_avc`` metadata record: the run's configuration, one YAML document per section
  (:data:`CONFIG_SECTIONS`, ``machine`` required) plus ``package_version`` and ``format``, so
  a bag is self-describing (DESIGN.md section 5).
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np
import yaml

from .. import __version__
from .errors import BagError

CONFIG_RECORD = "rotor_avc"
#: per topic: messages published (publishers' side), recorded, lost (written on close)
COUNTS_RECORD = "rotor_avc_counts"
FORMAT = "rotor_avc.bag/1"
#: configuration sections a run records; ``machine`` is required, the others may be null
CONFIG_SECTIONS = ("machine", "controllers", "discretisation", "balancer", "speed_profile",
                   "unbalance")
ROS_DISTRO = "jazzy"
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)      # libyaml when available
_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

_INFINITE = {"sec": 9223372036, "nsec": 854775807}     # RMW_DURATION_INFINITE as rmw reports it
DEFAULT_QOS = {
    "history": "keep_last", "depth": 10, "reliability": "reliable", "durability": "volatile",
    "deadline": dict(_INFINITE), "lifespan": dict(_INFINITE), "liveliness": "automatic",
    "liveliness_lease_duration": dict(_INFINITE), "avoid_ros_namespace_conventions": False,
}
#: the values rosbag2's QoS YAML decoder knows, per enumerated key
QOS_CHOICES = {
    "history": ("keep_last", "keep_all", "system_default", "unknown"),
    "reliability": ("reliable", "best_effort", "system_default", "best_available", "unknown"),
    "durability": ("volatile", "transient_local", "system_default", "best_available", "unknown"),
    "liveliness": ("automatic", "manual_by_topic", "system_default", "best_available", "unknown"),
}


def qos_profiles(profiles: list[Mapping] | None) -> list[dict]:
    """Complete and check QoS profiles (missing keys from :data:`DEFAULT_QOS`)."""
    out = []
    for i, given in enumerate(profiles if profiles is not None else [{}]):
        unknown = set(given) - set(DEFAULT_QOS)
        if unknown:
            raise BagError("(qos)", f"profile {i}: unknown keys {sorted(unknown)}",
                           fix="use " + ", ".join(DEFAULT_QOS))
        profile = {**DEFAULT_QOS, **given}
        for key, choices in QOS_CHOICES.items():
            if profile[key] not in choices:
                raise BagError("(qos)", f"profile {i}: {key} {profile[key]!r} is not one of "
                               + ", ".join(choices))
        out.append(profile)
    return out


def dump_yaml(value: Any) -> str:
    return yaml.dump(value, Dumper=_DUMPER, default_flow_style=False, sort_keys=False)


def load_yaml(text: str) -> Any:
    """Parse YAML text (raises yaml.YAMLError)."""
    return yaml.load(text, Loader=_LOADER)


def qos_yaml(profiles: list[dict]) -> str:
    return dump_yaml(profiles)


def parse_qos_yaml(text: str) -> list:
    """The profiles of an ``offered_qos_profiles`` entry ([] when absent or unreadable)."""
    try:
        profiles = load_yaml(text or "")
    except yaml.YAMLError:
        return []
    return profiles if isinstance(profiles, list) else []


def rosbag2_record(file_name: str, topics: list[dict], start_ns: int, end_ns: int,
                   compression: str) -> dict[str, str]:
    """The ``rosbag2`` metadata record; ``topics`` entries: name, type, qos, hash, count."""
    count = sum(t["count"] for t in topics)
    duration = max(0, end_ns - start_ns) if count else 0
    start = start_ns if count else 0
    info = {
        "version": 9, "storage_identifier": "mcap",
        "duration": {"nanoseconds": duration},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": count,
        "topics_with_message_count": [
            {"topic_metadata": {"name": t["name"], "type": t["type"],
                                "serialization_format": "cdr",
                                "offered_qos_profiles": t["qos"],
                                "type_description_hash": t["hash"]},
             "message_count": t["count"]} for t in topics],
        "compression_format": "", "compression_mode": "",
        "relative_file_paths": [file_name],
        "files": [{"path": file_name, "starting_time": {"nanoseconds_since_epoch": start},
                   "duration": {"nanoseconds": duration}, "message_count": count}],
        "custom_data": {"writer": f"rotor_avc {__version__}", "chunk_compression": compression},
        "ros_distro": ROS_DISTRO,
    }
    return {"serialized_metadata": dump_yaml(info)}


def _plain(value: Any, where: str) -> Any:
    """Numpy scalars/arrays and tuples -> plain YAML types; complex -> {re, im}."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v, f"{where}.{k}") for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, complex):
        return {"re": value.real, "im": value.imag}
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise BagError("(config)", f"{where}: {type(value).__name__} cannot be stored in a bag",
                   fix="give numbers, strings, lists and mappings only")


def encode_config(config: Mapping[str, Any]) -> dict[str, str]:
    """The ``rotor_avc`` record: each section as a YAML document (see module docstring)."""
    if not isinstance(config, Mapping) or not isinstance(config.get("machine"), Mapping):
        raise BagError("(config)", "the run configuration needs a `machine` mapping",
                       fix="pass {'machine': <machine config dict>, 'controllers': ..., "
                           "'discretisation': ..., ...}")
    record = {"format": FORMAT, "package_version": __version__}
    for key, value in config.items():
        if key in record:
            raise BagError("(config)", f"section name {key!r} is reserved")
        record[str(key)] = dump_yaml(_plain(value, str(key)))
    for key in CONFIG_SECTIONS:
        record.setdefault(key, dump_yaml(None))
    return record


def decode_config(record: Mapping[str, str], path) -> dict[str, Any]:
    """Inverse of :func:`encode_config` (``format`` and ``package_version`` kept as strings)."""
    out: dict[str, Any] = {}
    for key, text in record.items():
        if key in ("format", "package_version"):
            out[key] = text
            continue
        try:
            out[key] = load_yaml(text)
        except yaml.YAMLError as exc:
            raise BagError(path, f"configuration section {key!r} is not valid YAML ({exc})",
                           fix="the bag's metadata is damaged; re-record the run") from None
    if not isinstance(out.get("machine"), Mapping):
        raise BagError(path, "the configuration metadata has no `machine` section",
                       fix="re-record the run with the package's recorder or simulator")
    return out


def encode_counts(counts: Mapping[str, Mapping[str, int | None]]) -> dict[str, str]:
    """The ``rotor_avc_counts`` record: ``{topic: "published=N recorded=M lost=L"}``; a count
    nobody reported is ``?`` (e.g. the published count of a publisher outside this package)."""
    def text(v):
        return "?" if v is None else str(int(v))
    return {topic: " ".join(f"{k}={text(c.get(k))}" for k in ("published", "recorded", "lost"))
            for topic, c in sorted(counts.items())}


def decode_counts(record: Mapping[str, str], path) -> dict[str, dict[str, int | None]]:
    """Inverse of :func:`encode_counts`."""
    out = {}
    for topic, text in record.items():
        try:
            fields = dict(item.split("=", 1) for item in text.split())
            out[topic] = {k: None if fields[k] == "?" else int(fields[k])
                          for k in ("published", "recorded", "lost")}
        except (KeyError, ValueError):
            raise BagError(path, f"message counts of {topic} are unreadable ({text!r})",
                           fix="the bag's metadata is damaged; re-record the run") from None
    return out
