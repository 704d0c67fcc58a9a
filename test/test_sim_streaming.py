"""Long simulations stream to their output block by block: the streamed bag holds exactly the
messages of the bag written from the whole run and the streamed .npz its arrays, memory does not
grow with the duration, runs held in memory are size-checked first, Ctrl-C leaves a valid partial
bag (or no file), and --out paths that cannot be written are refused up front."""
import os
import signal
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from rotor_avc.bag import BagReader
from rotor_avc.bag.sequence import check_sequence
from rotor_avc.cli import main
from rotor_avc.cli.common import EXIT_INTERRUPTED
from rotor_avc.config import find_config, load_yaml
from rotor_avc.recording import stream_run_bag, write_run_bag
from rotor_avc.resources import ENV_VAR, ResourceError
from rotor_avc.scenario import load_scenario, scenario_from_config
from rotor_avc.sim.loop import BLOCK_STEPS
from rotor_avc.sim.timeseries import TimeSeries, save_blocks

ROOT = Path(__file__).resolve().parents[1]


def short_scenario(tmp_path, duration_s, name="short.yaml", extra=""):
    cfg = tmp_path / name
    cfg.write_text(f"include: {ROOT / 'config' / 'scenario_case3_steady.yaml'}\n"
                   f"simulation: {{duration_s: {duration_s}{extra}}}\n")
    return cfg


def messages(path):
    with BagReader(path) as bag:
        return [(m.topic, m.time_ns, m.sequence, bytes(m.data)) for m in bag.raw_messages()]


@pytest.mark.parametrize("block_steps", [137, 500])
def test_streamed_bag_equals_the_bag_of_the_whole_run(tmp_path, block_steps):
    data = load_yaml(find_config("foot_mount_case3"))
    data["simulation"] = {"sample_rate_hz": 5000.0, "duration_s": 0.1,
                          "speed": {"type": "constant", "speed_hz": 25.0},
                          "unbalance": {"static": {"magnitude": 1.0e-2}},
                          "test_signal": {"actuator": "DL", "kind": "white", "rms_n": 50.0,
                                          "band_hz": [20.0, 300.0], "seed": 3}}
    sc = scenario_from_config(data, "test")
    whole = write_run_bag(tmp_path / "whole.mcap", sc, sc.run())
    blocks = sc.run_blocks(block_steps=block_steps)
    lengths = [len(ts) for ts in stream_run_bag(tmp_path / "streamed.mcap", sc, blocks)]
    assert sum(lengths) == sc.n_steps == 500 and max(lengths) == block_steps
    expected, got = messages(whole), messages(tmp_path / "streamed.mcap")
    assert len(got) == len(expected) and got == expected


def test_streamed_npz_equals_the_whole_run(tmp_path):
    sc = load_scenario(str(short_scenario(tmp_path, 0.1)))
    whole = sc.run()
    lengths = [len(ts) for ts in save_blocks(tmp_path / "s.npz", sc.run_blocks(block_steps=137),
                                             sc.n_steps)]
    assert lengths == [137, 137, 137, 89]
    got = TimeSeries.load(tmp_path / "s.npz")
    assert got.units == whole.units and got.metadata.keys() == whole.metadata.keys()
    for name in ("time_s", "speed_rad_s", "accel_rad_s2", "angle_rad"):
        np.testing.assert_array_equal(getattr(got, name), getattr(whole, name))
    assert got.channels.keys() == whole.channels.keys()
    for name, values in whole.channels.items():
        np.testing.assert_array_equal(got.channels[name], values)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.npz", "short.yaml"]


def _peak_bytes(sc, path):
    blocks = sc.run_blocks(block_steps=400)
    tracemalloc.start()
    for _ in (stream_run_bag(path, sc, blocks) if path.suffix == ".mcap"
              else save_blocks(path, blocks, sc.n_steps)):
        pass
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak


@pytest.mark.parametrize("suffix", [".mcap", ".npz"])
def test_streamed_memory_does_not_grow_with_the_duration(tmp_path, suffix):
    short = load_scenario(str(short_scenario(tmp_path, 0.96, "a.yaml")))     # 12 blocks
    long = load_scenario(str(short_scenario(tmp_path, 2.88, "b.yaml")))      # 36 blocks
    p_short = _peak_bytes(short, tmp_path / f"a{suffix}")
    p_long = _peak_bytes(long, tmp_path / f"b{suffix}")
    print(f"{suffix}: peak traced memory {p_short / 1e6:.2f} MB for 0.96 s, "
          f"{p_long / 1e6:.2f} MB for 2.88 s")
    assert p_long < 1.25 * p_short


def test_a_run_held_in_memory_is_refused_above_the_limit(tmp_path, capsys, monkeypatch):
    huge = load_scenario(str(short_scenario(tmp_path, "1.0e+4")))
    with pytest.raises(ResourceError, match=r"a run of 50000000 samples held in memory needs"):
        huge.run()
    monkeypatch.setenv(ENV_VAR, "0.0001")                    # 100 kiB: a 0.05 s run needs more
    small = short_scenario(tmp_path, 0.05, "small.yaml")
    with pytest.raises(ResourceError, match=r"write it to a .mcap bag"):
        load_scenario(str(small)).run()
    for suffix in (".mcap", ".npz"):                         # streamed: within the limit
        assert main(["simulate", str(small), "--out", str(tmp_path / f"s{suffix}")]) == 0
    assert len(TimeSeries.load(tmp_path / "s.npz")) == 250
    with BagReader(tmp_path / "s.mcap") as bag:
        assert check_sequence(bag, 250).ok


#: samples of the run the signal tests interrupt once its first block is out (a few seconds of
#: run left: the signal arrives while it runs)
SIGNALLED_SAMPLES = 3_000_000


def _simulate(tmp_path, out):
    cfg = short_scenario(tmp_path, SIGNALLED_SAMPLES / 5000.0)
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1")
    return subprocess.Popen([sys.executable, "-m", "rotor_avc", "simulate", str(cfg), "--out",
                             str(out)], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def _wait_for(condition, timeout_s=60.0):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "the simulation did not get ready"
        time.sleep(0.02)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_or_kill_leaves_a_valid_partial_bag(tmp_path, sig):
    out = tmp_path / "run.mcap"
    proc = _simulate(tmp_path, out)
    _wait_for(lambda: (tmp_path / ".run.partial.mcap").exists())      # the run has started
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_INTERRUPTED, stderr
    assert "Traceback" not in stderr and "valid partial run" in stdout
    assert not (tmp_path / ".run.partial.mcap").exists()
    with BagReader(out) as bag:
        bag.check(require_config=True)
        report = check_sequence(bag, SIGNALLED_SAMPLES)
    assert report.ok and BLOCK_STEPS <= report.samples < SIGNALLED_SAMPLES
    assert report.samples % BLOCK_STEPS == 0 and "incomplete run" in report.notes[-1]


def test_ctrl_c_during_an_npz_run_leaves_no_file(tmp_path):
    out = tmp_path / "run.npz"
    proc = _simulate(tmp_path, out)
    assert "samples" in proc.stdout.readline()          # printed just before the run starts
    _wait_for(lambda: any(tmp_path.glob("*/0.npy")))     # the first block is written
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_INTERRUPTED and "interrupted" in stdout + stderr, stderr
    assert "Traceback" not in stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["short.yaml"]     # no file, no temp


@pytest.mark.parametrize("argv", [
    ["simulate", "scenario_case3_steady", "--out", "{file}/run.mcap"],
    ["simulate", "scenario_case3_steady", "--out", "{tmp}"],
    ["simulate", "scenario_case3_steady", "--out", "{tmp}/run.csv"],
    ["frf", "foot_mount_case3", "--out", "{file}"],
    ["frf", "foot_mount_case3", "--out", "{file}/sub"],
    ["compare", "bags/reference/case3_stepped.mcap", "--out", "{file}"],
    ["controller", "foot_mount_case3", "--foot", "DL", "--out", "{file}"],
    ["campbell", "foot_mount_case3", "--out", "{file}"],
])
def test_unwritable_out_is_refused_before_the_work(tmp_path, capsys, argv):
    (tmp_path / "f").write_text("a file\n")
    argv = [a.format(file=tmp_path / "f", tmp=tmp_path) for a in argv]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "argument --out" in err and "Traceback" not in err
    assert "fix:" in err or "must end in .mcap or .npz" in err
