"""Malformed input to `rotor-avc compare`: a truncated bag, a bag with an unknown schema, a bag
without configuration metadata, an empty bag (and a few more) each end with one clear line on
stderr and exit status 2, never a traceback."""
from pathlib import Path

import numpy as np
import pytest

from rotor_avc.bag import BagReader, BagWriter, topics as T
from rotor_avc.bag.mcap_writer import McapSink
from rotor_avc.bag.metadata import CONFIG_RECORD, encode_config
from rotor_avc.cli import main

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "bags" / "reference" / "case3_stepped.mcap"


@pytest.fixture(scope="module")
def config():
    with BagReader(REFERENCE, require_config=True) as bag:
        cfg = bag.config
    return {k: v for k, v in cfg.items() if k not in ("format", "package_version")}


def compare(path, tmp_path, capsys) -> str:
    status = main(["compare", str(path), "--out", str(tmp_path / "report")])
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("rotor-avc compare: error: ")
    assert not (tmp_path / "report").exists()
    return err


def test_truncated_bag(tmp_path, capsys):
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(REFERENCE.read_bytes()[:100_000])
    assert "truncated" in compare(cut, tmp_path, capsys)


def test_unknown_schema(tmp_path, capsys, config):
    path = tmp_path / "foreign.mcap"
    with open(path, "wb") as f:
        sink = McapSink(f, "ros2", "test")
        sink.add_metadata(CONFIG_RECORD, encode_config(config))
        sid = sink.add_schema("sensor_msgs/msg/JointState", "protobuf", b"syntax = 'proto3';")
        cid = sink.add_channel("/avc/rotor/joint_state", "cdr", sid, {})
        sink.add_message(cid, 5, 5, 1, b"\x00\x01\x00\x00" + bytes(8))
        sink.finish()
    err = compare(path, tmp_path, capsys)
    assert "/avc/rotor/joint_state: unknown schema 'sensor_msgs/msg/JointState'" in err


def test_bag_without_configuration(tmp_path, capsys):
    path = tmp_path / "noconf.mcap"
    with BagWriter(path, None) as w:
        w.write_streams([T.joint_state(np.arange(10) * 1e-3, np.arange(10.0), np.ones(10))])
    assert "carries no run configuration" in compare(path, tmp_path, capsys)


def test_empty_bag(tmp_path, capsys, config):
    path = tmp_path / "empty.mcap"
    with BagWriter(path, config) as w:
        w.add_topic("/avc/rotor/joint_state")
    assert "holds no messages" in compare(path, tmp_path, capsys)


def test_zero_byte_and_missing_files(tmp_path, capsys):
    (tmp_path / "zero.mcap").write_bytes(b"")
    assert "empty file (0 bytes)" in compare(tmp_path / "zero.mcap", tmp_path, capsys)
    assert "no such bag file" in compare(tmp_path / "nope.mcap", tmp_path, capsys)


def test_bag_without_the_shaft_angle(tmp_path, capsys, config):
    path = tmp_path / "noangle.mcap"
    with BagWriter(path, config) as w:
        w.write_streams([T.clock(np.arange(10) * 1e-3)])
    assert "no rotor/joint_state topic" in compare(path, tmp_path, capsys)


def test_bag_with_a_broken_configuration(tmp_path, capsys, config):
    """A recorded machine config that no longer validates names the field and the bag."""
    broken = dict(config, machine={**config["machine"], "simulation": {
        **config["machine"]["simulation"], "sample_rate_hz": -5.0}})
    path = tmp_path / "broken.mcap"
    with BagWriter(path, broken) as w:
        w.write_streams([T.clock(np.arange(10) * 1e-3)])
    err = compare(path, tmp_path, capsys)
    assert "broken.mcap (recorded configuration): simulation.sample_rate_hz: must be > 0" in err
