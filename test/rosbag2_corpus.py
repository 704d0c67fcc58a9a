"""A corpus of "real machine" recordings for the tests: simulated runs of the shipped machines
written by an independent writer (rosbags' rosbag2 Writer, version 9, MCAP storage) as a
rosbag2 directory of two split files with one metadata.yaml in rosbag2's own format, with no
rotor_avc metadata, driver-style topics and stated imperfections (:class:`Imperfections`):

* accelerometers as sensor_msgs/Imu (``/imu_foot_<id>/data``, ``linear_acceleration.z``) at the
  run's 5 kHz; one of them mounted upside down and publishing in g;
* bearing-housing velocities as geometry_msgs/Vector3Stamped at half the rate;
* actuator and test forces as geometry_msgs/WrenchStamped;
* a once-per-revolution tacho pulse (std_msgs/Header, stamped at the pulse) instead of the
  shaft angle;
* white sensor noise at ``snr_db`` below each channel's RMS, stamp jitter (std ``jitter_s``) on
  the sensor clock, ``drop_fraction`` of the messages of every topic dropped at random, log
  times = stamps + a random transport latency.
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.stores.ros2_jazzy import (builtin_interfaces__msg__Time as Time,
                                               geometry_msgs__msg__Quaternion as Quaternion,
                                               geometry_msgs__msg__Vector3 as Vector3,
                                               geometry_msgs__msg__Vector3Stamped as Vector3Stamped,
                                               geometry_msgs__msg__Wrench as Wrench,
                                               geometry_msgs__msg__WrenchStamped as WrenchStamped,
                                               sensor_msgs__msg__Imu as Imu,
                                               std_msgs__msg__Header as Header)

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
G = 9.80665
#: sensor clock at the run's t = 0 (a wall-clock epoch, as drivers stamp)
EPOCH_NS = 1_764_600_000_000_000_000
#: the upside-down accelerometer publishing in g
INVERTED = "DL"


@dataclass(frozen=True)
class Imperfections:
    snr_db: float = 30.0
    jitter_s: float = 2e-6
    drop_fraction: float = 0.01
    latency_s: float = 200e-6
    seed: int = 0


def _header(t_ns: int, frame: str) -> Header:
    return Header(Time(int(t_ns // 1_000_000_000), int(t_ns % 1_000_000_000)), frame)


def _imu(t_ns, a, frame):
    z = np.zeros(9)
    return Imu(_header(t_ns, frame), Quaternion(0.0, 0.0, 0.0, 1.0), z, Vector3(0.0, 0.0, 0.0),
               z, Vector3(0.0, 0.0, float(a)), z)


def _wrench(t_ns, f, frame):
    return WrenchStamped(_header(t_ns, frame),
                         Wrench(Vector3(0.0, 0.0, float(f)), Vector3(0.0, 0.0, 0.0)))


def _vector(t_ns, v, frame):
    return Vector3Stamped(_header(t_ns, frame), Vector3(float(v[0]), float(v[1]), float(v[2])))


def pulse_times(time_s, angle_rad) -> np.ndarray:
    """When the simulated shaft angle passes whole revolutions (linear between samples)."""
    turns = 2 * np.pi * np.arange(np.ceil(angle_rad[0] / (2 * np.pi)),
                                  np.floor(angle_rad[-1] / (2 * np.pi)) + 1)
    return np.interp(turns, angle_rad, time_s)


def sensor_topics(ts, test_force: bool):
    """topic -> (msg type, maker, sample times s, values per sample, decimation)."""
    topics = {}
    for foot in ("DL", "DR", "NL"):
        a = ts.channels[f"foot_{foot}_az"]
        a = -a / G if foot == INVERTED else a
        topics[f"/imu_foot_{foot.lower()}/data"] = (Imu, _imu, a, 1)
    for b in ("D", "N"):
        v = np.column_stack([ts.channels[f"bearing_{b}_v{ax}"] for ax in "xyz"])
        topics[f"/velocity_bearing_{b.lower()}/data"] = (Vector3Stamped, _vector, v, 2)
    topics["/actuator_dl/wrench"] = (WrenchStamped, _wrench, ts.channels["actuator_DL_fz"], 1)
    if test_force:
        topics["/shaker/force"] = (WrenchStamped, _wrench, ts.channels["test_signal_DL_fz"], 1)
    return topics


def _ns(seconds) -> np.ndarray:
    return np.round(np.asarray(seconds) * 1e9).astype(np.int64)


def _messages(ts, imp: Imperfections, test_force: bool, rng):
    """(log ns, topic, msg type, CDR bytes), unsorted."""
    out = []
    t = np.asarray(ts.time_s)
    for topic, (cls, make, values, step) in sensor_topics(ts, test_force).items():
        y = np.asarray(values, float)[::step]
        tk = t[::step]
        rms = np.std(y, axis=0)
        y = y + rng.standard_normal(y.shape) * rms * 10 ** (-imp.snr_db / 20)
        keep = rng.random(tk.size) >= imp.drop_fraction
        stamp = EPOCH_NS + _ns(tk + imp.jitter_s * rng.standard_normal(tk.size))
        log = stamp + _ns(imp.latency_s * rng.random(tk.size))
        for k in np.flatnonzero(keep):
            out.append((int(log[k]), topic, cls,
                        TYPESTORE.serialize_cdr(make(int(stamp[k]), y[k], topic), cls.__msgtype__)))
    pulses = pulse_times(t, np.asarray(ts.angle_rad))
    keep = rng.random(pulses.size) >= imp.drop_fraction
    stamp = EPOCH_NS + _ns(pulses + imp.jitter_s * rng.standard_normal(pulses.size))
    for k in np.flatnonzero(keep):
        out.append((int(stamp[k]) + int(imp.latency_s * 1e9), "/tacho/pulse", Header,
                    TYPESTORE.serialize_cdr(_header(int(stamp[k]), "tacho"), Header.__msgtype__)))
    return out


def _write_part(path: Path, messages) -> dict:
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for log, topic, msgtype, data in messages:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=TYPESTORE)
            w.write(conns[topic], log, data)
    return yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


def write_corpus_bag(directory, ts, imp: Imperfections = Imperfections(), *,
                     test_force: bool = False) -> Path:
    """The run ``ts`` (rotor_avc.sim.timeseries.TimeSeries) as a two-file rosbag2 directory."""
    rng = np.random.default_rng(imp.seed)
    return write_split_bag(directory, [(log, topic, cls.__msgtype__, data) for log, topic, cls, data
                                       in _messages(ts, imp, test_force, rng)])


def write_split_bag(directory, messages) -> Path:
    """``(log ns, topic, msg type, CDR bytes)`` as a rosbag2 directory of two files, split at
    the middle message, with one metadata.yaml in rosbag2's format listing both."""
    directory = Path(directory)
    messages = sorted(messages, key=lambda m: m[0])
    half = len(messages) // 2
    scratch = directory.parent / f"{directory.name}_parts"
    parts = [_write_part(scratch / f"{directory.name}_{i}", chunk)
             for i, chunk in enumerate((messages[:half], messages[half:]))]
    directory.mkdir(parents=True)
    files, counts = [], {}
    for i, info in enumerate(parts):
        [name] = info["relative_file_paths"]
        shutil.move(scratch / f"{directory.name}_{i}" / name, directory / name)
        files += info["files"]
        for t in info["topics_with_message_count"]:
            key = t["topic_metadata"]["name"]
            counts.setdefault(key, {**t, "message_count": 0})["message_count"] += t["message_count"]
    shutil.rmtree(scratch)
    start = parts[0]["starting_time"]["nanoseconds_since_epoch"]
    end = max(f["starting_time"]["nanoseconds_since_epoch"] + f["duration"]["nanoseconds"]
              for f in files)
    info = {**parts[0], "relative_file_paths": [f["path"] for f in files], "files": files,
            "message_count": sum(p["message_count"] for p in parts),
            "duration": {"nanoseconds": end - start},
            "topics_with_message_count": list(counts.values())}
    (directory / "metadata.yaml").write_text(
        yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False))
    return directory


def corpus_map(*, test_force: bool, bearings: bool = True) -> dict:
    """The mapping file of a corpus bag (rotor_avc.compare.recording_map)."""
    channels = {f"foot_{f}_az": {"topic": f"/imu_foot_{f.lower()}/data",
                                 "field": "linear_acceleration.z",
                                 **({"sign": -1, "scale": G} if f == INVERTED else {})}
                for f in ("DL", "DR", "NL")}
    if bearings:
        for b in ("D", "N"):
            channels[f"bearing_{b}_vz"] = {"topic": f"/velocity_bearing_{b.lower()}/data",
                                           "field": "vector.z"}
    channels["actuator_DL_fz"] = {"topic": "/actuator_dl/wrench", "field": "wrench.force.z"}
    out = {"channels": channels, "shaft": {"source": "pulse", "topic": "/tacho/pulse"}}
    if test_force:
        out["test_force"] = {"topic": "/shaker/force", "field": "wrench.force.z"}
    return out


def corpus_recording(root: Path) -> Path:
    """0.4 s of Werner 2021 case 3 at 25 Hz as a two-file directory ``root/bag`` (imperfections
    of seed 3), beside its machine config ``root/machine.yaml`` and mapping ``root/map.yaml``;
    returns the directory."""
    from rotor_avc.config import find_config, load_yaml
    from rotor_avc.scenario import scenario_from_config
    data = load_yaml(find_config("foot_mount_case3"))
    data["simulation"] = {"sample_rate_hz": 5000.0, "duration_s": 0.4,
                          "speed": {"type": "constant", "speed_hz": 25.0},
                          "unbalance": {"static": {"magnitude": 1e-2, "phase_deg": 0.0}},
                          "initial_state": "steady_state"}
    (root / "machine.yaml").write_text(yaml.safe_dump(data))
    ts = scenario_from_config(data, "dir").run(progress=False)
    bag = write_corpus_bag(root / "bag", ts, Imperfections(seed=3))
    (root / "map.yaml").write_text(yaml.safe_dump(corpus_map(test_force=False)))
    return bag
