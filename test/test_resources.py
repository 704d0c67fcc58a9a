"""Bounded resources: planned allocations and study run times are estimated first and refused
above their limits with one clear line (exit status 2); FRF grids evaluated in chunks give the
same responses as one batch."""
import numpy as np
import pytest

from rotor_avc import resources
from rotor_avc.cli import main
from rotor_avc.closed_loop.frf import unbalance_frf
from rotor_avc.config import find_config
from rotor_avc.machine import load_machine
from rotor_avc.resources import ENV_VAR, TIME_ENV_VAR, ResourceError

VARY = "foundation.stiffness_n_per_m.z=2.0e+7:7.5e+8:{n}"


@pytest.mark.parametrize("config", ["foot_mount_case3", "sleeve_bearing_motor"])
def test_frf_in_chunks_equals_one_batch(config, monkeypatch):
    loop = load_machine(config).loop
    speeds = 2 * np.pi * np.linspace(5.0, 60.0, 301)
    whole = unbalance_frf(loop, speeds)
    monkeypatch.setattr(resources, "CHUNK_BYTES", 40_000)           # a few speeds per chunk
    assert len(list(resources.chunks(301, 16 * 2 * len(loop.plant.coords) ** 2))) > 10
    chunked = unbalance_frf(loop, speeds)
    assert chunked.responses.keys() == whole.responses.keys()
    for key, value in whole.responses.items():
        np.testing.assert_allclose(chunked.responses[key], value, rtol=1e-9,
                                   atol=1e-12 * np.max(np.abs(value)))


def test_frf_above_the_memory_limit_is_refused(monkeypatch, capsys):
    monkeypatch.setenv(ENV_VAR, "0.001")                              # 1 MiB
    loop = load_machine("foot_mount_case3").loop
    with pytest.raises(ResourceError, match=r"an FRF over 20000 speeds needs about .* GiB"):
        unbalance_frf(loop, 2 * np.pi * np.linspace(1.0, 250.0, 20_000))
    with pytest.raises(SystemExit) as exc:                           # the grid itself, parsed
        main(["frf", "foot_mount_case3", "--speed-hz", "1:250:1000000000000", "--out", "x"])
    assert exc.value.code == 2 and "1000000000000 speeds needs about" in capsys.readouterr().err


def test_a_huge_study_grid_is_refused_before_it_starts(tmp_path, capsys):
    argv = ["stability", "roller_bearing_stability", "--vary", VARY.format(n=10**12),
            "--workers", "1", "--out", str(tmp_path / "s")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "1000000000000 values needs about" in err and "--max-memory-gb" in err


def test_a_study_estimated_beyond_the_time_limit_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv(TIME_ENV_VAR, "1e4")          # restored after the test
    argv = ["stability", "roller_bearing_stability", "--vary", VARY.format(n=60),
            "--workers", "1", "--max-hours", "1.0e-5", "--out", str(tmp_path / "s")]
    assert main(argv) == 2                           # 36 ms allowed; each point takes longer
    err = capsys.readouterr().err
    assert "remaining points at" in err and "would take about" in err and "--max-hours" in err


@pytest.mark.parametrize("value", ["0", "-3", "lots", "nan"])
def test_a_bad_limit_is_named(monkeypatch, value):
    monkeypatch.setenv(ENV_VAR, value)
    with pytest.raises(ResourceError, match=f"{ENV_VAR} .--max-memory-gb. must be a number"):
        resources.memory_limit_bytes()


@pytest.mark.parametrize("suffix", [".mcap", ".npz"])
def test_a_simulation_beyond_the_time_or_disk_limit_stops_after_its_first_block(
        tmp_path, capsys, monkeypatch, suffix):
    """A million-second run (5e9 samples) streams with bounded memory, but its time or its
    output (about 1 TB), extrapolated from the first block, is far beyond the default 24 h or
    this disk: refused, and nothing is left."""
    monkeypatch.delenv(TIME_ENV_VAR, raising=False)
    config = tmp_path / "long.yaml"
    config.write_text(f"include: {find_config('scenario_case3_steady')}\n"
                      "simulation: {duration_s: 1000000.0}\n")
    assert main(["simulate", str(config), "--out", str(tmp_path / f"long{suffix}")]) == 2
    err = capsys.readouterr().err
    assert ("the run of 5000000000 samples would take about" in err and "--max-hours" in err
            or "the output of 5000000000 samples needs about" in err and "GiB free" in err), err
    assert list(tmp_path.iterdir()) == [config]


def test_a_simulation_output_beyond_the_free_disk_space_is_refused(tmp_path, capsys,
                                                                   monkeypatch):
    monkeypatch.setenv(TIME_ENV_VAR, "1e9")
    monkeypatch.setattr(resources.shutil, "disk_usage",
                        lambda path: type("Usage", (), {"free": 10 * 2**20})())
    config = tmp_path / "long.yaml"
    config.write_text(f"include: {find_config('scenario_case3_steady')}\n"
                      "simulation: {duration_s: 100.0}\n")
    assert main(["simulate", str(config), "--out", str(tmp_path / "long.mcap")]) == 2
    err = capsys.readouterr().err
    assert "the output of 500000 samples needs about" in err and "GiB free" in err
    assert list(tmp_path.iterdir()) == [config]
