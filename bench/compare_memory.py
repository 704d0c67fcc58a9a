"""Peak memory and time of ``rotor-avc compare`` against the recording's length: the streamed
bag source (the default) against the in-memory path (``--in-memory``, the baseline).

The recordings are seed 000 case 3 at a constant 20 Hz and 5 kHz (``scenario_case3_steady``),
started on the sampled loop's periodic steady state: 250 samples per revolution, so a 2 s run
(40 revolutions) repeats exactly, and a run of any length is written by repeating it (time
and shaft angle continued) without ever holding more than 2 s in memory. Each comparison runs
in its own process; its peak resident memory (``ru_maxrss``) and wall time are printed with the
growth per second of run and the ratio streamed / in-memory at the same length.

``--runup``: the recordings are run-ups instead (no dwells: the order tracking runs over
windows of whole revolutions, streamed block by block), seed 000 case 3 at 1 kHz from 5 to
60 Hz over the run's length, each simulated and written by ``rotor-avc simulate`` (streamed).

Run: ``python bench/compare_memory.py`` (2, 10, 40 s), ``--long`` (2, 120, 600, 3600 s; the
in-memory baseline only up to 120 s: beyond, it needs about 10 MB per second of run), or
``--lengths 2 20``; each with ``--runup``.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from rotor_avc.bag.writer import BagWriter
from rotor_avc.config import find_config, load_yaml
from rotor_avc.recording import run_streams
from rotor_avc.scenario import scenario_from_config

TILE_S = 2.0
IN_MEMORY_UP_TO_S = 120.0
CHILD = """
import json, resource, sys, time
from rotor_avc.compare.comparison import compare_bag
t0 = time.perf_counter()
comp = compare_bag(sys.argv[1], in_memory=sys.argv[2] == "memory")
print(json.dumps({"time_s": time.perf_counter() - t0, "verdict": comp.verdict,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def scenario(duration_s: float):
    data = load_yaml(find_config("scenario_case3_steady"))
    data["simulation"]["duration_s"] = duration_s
    return scenario_from_config(data, "bench")


def write_recording(path: Path, duration_s: float) -> Path:
    """A ``duration_s`` run, written 2 s at a time from one simulated periodic 2 s."""
    tile = scenario(TILE_S)
    ts = tile.run(progress=False)
    revolutions = round(float(ts.speed_rad_s[0]) * TILE_S / (2 * np.pi))
    assert abs(ts.speed_rad_s[0] * TILE_S / (2 * np.pi) - revolutions) < 1e-9
    with BagWriter(path, scenario(duration_s).run_config()) as bag:
        for i in range(int(round(duration_s / TILE_S))):
            shifted = dataclasses.replace(ts, time_s=ts.time_s + i * TILE_S,
                                          angle_rad=ts.angle_rad + 2 * np.pi * revolutions * i)
            bag.write_streams(run_streams(tile, shifted))
    return path


def write_runup(path: Path, duration_s: float) -> Path:
    """A ``duration_s`` run-up 5 -> 60 Hz at 1 kHz, simulated and written by ``rotor-avc
    simulate`` (streamed block by block: its memory does not grow with the length)."""
    data = load_yaml(find_config("foot_mount_case3"))
    data["simulation"] = {"sample_rate_hz": 1000.0, "initial_state": "steady_state",
                          "speed": {"type": "ramp", "start_hz": 5.0, "stop_hz": 60.0,
                                    "duration_s": duration_s},
                          "unbalance": {"static": {"magnitude": 1.0e-2, "phase_deg": 0.0}}}
    config = path.with_suffix(".yaml")
    config.write_text(json.dumps(data))
    subprocess.run([sys.executable, "-m", "rotor_avc", "simulate", str(config), "--out", str(path),
                    "--max-hours", "4"], check=True, capture_output=True)
    return path


def measure(path: Path, mode: str) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, str(path), mode], capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--long", action="store_true", help="2 s to 1 h")
    parser.add_argument("--lengths", type=float, nargs="+", help="run lengths in s")
    parser.add_argument("--runup", action="store_true", help="run-ups instead of a held speed")
    args = parser.parse_args()
    write = write_runup if args.runup else write_recording
    lengths = args.lengths or ([2.0, 120.0, 600.0, 3600.0] if args.long else [2.0, 10.0, 40.0])
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for length in lengths:
            path = write(Path(folder) / f"run_{length:g}s.mcap", length)
            row = {"length_s": length, "bag_mb": path.stat().st_size / 2 ** 20,
                   "streamed": measure(path, "streamed")}
            if length <= IN_MEMORY_UP_TO_S:
                row["in_memory"] = measure(path, "memory")
            path.unlink()
            rows.append(row)
            s, m = row["streamed"], row.get("in_memory")
            ratio = (f"{s['peak_mb'] / m['peak_mb']:.2f} memory, "
                     f"{s['time_s'] / m['time_s']:.2f} time" if m else "baseline not run")
            print(f"{length:7g} s run ({row['bag_mb']:.1f} MB bag): streamed {s['peak_mb']:.0f} MB "
                  f"{s['time_s']:.1f} s [{s['verdict']}]"
                  + (f"; in-memory {m['peak_mb']:.0f} MB {m['time_s']:.1f} s [{m['verdict']}]"
                     if m else "") + f"; streamed/in-memory: {ratio}", flush=True)
    for first, last in zip(rows[:-1], rows[1:]):
        growth = [f"{mode} {(last[mode]['peak_mb'] - first[mode]['peak_mb']) / span:.3f}"
                  for mode in ("streamed", "in_memory") if mode in first and mode in last
                  for span in [last["length_s"] - first["length_s"]]]
        print(f"peak memory growth from {first['length_s']:g} to {last['length_s']:g} s of run, "
              f"MB per second of run: {', '.join(growth)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
