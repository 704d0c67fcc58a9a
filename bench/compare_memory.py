"""Peak memory and time of ``rotor-avc compare`` against the recording's length: the streamed
bag source (the default) against the in-memory path (``--in-memory``, the baseline).

The recordings are Werner 2021 case 3 at a constant 20 Hz and 5 kHz (``scenario_case3_steady``),
started on the sampled loop's periodic steady state: 250 samples per revolution, so a 2 s run
(40 revolutions) repeats exactly, and a run of any length is written by repeating it (time
and shaft angle continued) without ever holding more than 2 s in memory. Each comparison runs
in its own process, the two paths interleaved at each length; its peak resident memory
(``ru_maxrss``; the largest of the repeats), CPU and wall time of the comparison (each the best of
the repeats) are printed with the growth per second of run and the ratios streamed / in-memory
at the same length.

``--runup``: the recordings are run-ups instead (no dwells: the order tracking runs over
windows of whole revolutions, streamed block by block), Werner 2021 case 3 at 1 kHz from 5 to
60 Hz over the run's length, each simulated and written by ``rotor-avc simulate`` (streamed).

``--mapped``: those run-ups recorded as a rig's drivers would and compared through a mapping
(``--config``/``--map``): a tacho pulse per revolution, the foot accelerations and bearing
velocities as stamped messages with 20 us stamp jitter, 400 us latency plus an exponential tail
and 1.2 % of the samples dropped (half in bursts of 5-60), written block by block from the
simulated bag; streamed (the default for a recording without a test force) against
``--in-memory`` (the whole recording on a resampling grid).

Run: ``python bench/compare_memory.py`` (2, 10, 40 s), ``--long`` (2, 120, 600, 3600 s; the
in-memory baseline only up to 120 s: beyond, it needs about 10 MB per second of run), or
``--lengths 2 20``; each with ``--runup`` or ``--mapped``, and ``--repeats N`` (default 1).
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

from timing import interleaved, load_line, result
from rotor_avc.bag.topics import Stream
from rotor_avc.bag.writer import BagWriter
from rotor_avc.config import find_config, load_yaml
from rotor_avc.recording import run_streams
from rotor_avc.scenario import scenario_from_config

TILE_S = 2.0
IN_MEMORY_UP_TO_S = 120.0
CHILD = f"""
import json, resource, sys
sys.path.insert(0, {str(Path(__file__).resolve().parent)!r})
from timing import timed
from rotor_avc.compare.comparison import compare_bag
from rotor_avc.compare.mapped_stream import compare_mapped
out = {{}}
if len(sys.argv) > 3:
    run = lambda: compare_mapped(sys.argv[1], sys.argv[3], sys.argv[4],
                                 in_memory=sys.argv[2] == "memory")
else:
    run = lambda: compare_bag(sys.argv[1], in_memory=sys.argv[2] == "memory")
cpu_s, time_s = timed(lambda: out.setdefault("comp", run()))
print(json.dumps({{"time_s": time_s, "cpu_s": cpu_s, "verdict": out["comp"].verdict,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}}))
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


#: the rig: sensor rates (divide the 1 kHz run), stamp jitter, latency and its tail, drops
RIG = {"foot_DL_az": 1000.0, "foot_DR_az": 1000.0, "foot_NL_az": 1000.0, "bearing_D_vz": 500.0,
       "bearing_N_vz": 500.0}
JITTER_S, LATENCY_S, TAIL_S, DROPPED = 20e-6, 400e-6, 300e-6, 0.012


def _rig_stamps(t, rng):
    """(header stamps, log times) in ns of samples at ``t`` s, and the samples kept."""
    keep = rng.random(t.size) >= 0.5 * DROPPED
    budget = int(0.5 * DROPPED * t.size)
    while budget > 0:
        length = int(rng.integers(5, 61))
        start = int(rng.integers(0, max(1, t.size - length)))
        keep[start:start + length] = False
        budget -= length
    stamp = np.round((t + JITTER_S * rng.standard_normal(t.size)) * 1e9).astype(np.int64)
    log = stamp + np.round((LATENCY_S + rng.exponential(TAIL_S, t.size)) * 1e9).astype(np.int64)
    return stamp[keep], log[keep], keep


def _stamped(topic: str, msg_type: str, stamp, log, fields: dict) -> Stream:
    order = np.argsort(log, kind="stable")
    header = "" if msg_type == "std_msgs/msg/Header" else "header."
    template = ({"frame_id": topic[1:]} if not header else {"header": {"frame_id": topic[1:]}})
    return Stream(topic, msg_type, log[order], template,
                  {f"{header}stamp.sec": (stamp // 1_000_000_000)[order],
                   f"{header}stamp.nanosec": (stamp % 1_000_000_000)[order],
                   **{k: v[order] for k, v in fields.items()}})


def write_mapped(path: Path, duration_s: float) -> tuple[Path, Path, Path]:
    """The run-up of :func:`write_runup` as a rig records it (module docstring), written block
    by block: ``(bag, config, map)``."""
    from rotor_avc.compare.bag_source import BagSource
    simulated = write_runup(path.with_name(path.stem + "_sim.mcap"), duration_s)
    rng = np.random.default_rng(7)
    turns = 0
    with BagWriter(path, None) as bag:
        for t, angle, _, channels, _ in BagSource(simulated).blocks():
            streams = []
            for name, rate in RIG.items():
                step = int(round(1000.0 / rate))
                stamp, log, keep = _rig_stamps(t[::step], rng)
                streams.append(_stamped(f"/rig/{name}", "geometry_msgs/msg/PointStamped", stamp,
                                        log, {"point.z": channels[name][::step][keep]}))
            marks = 2 * np.pi * np.arange(turns, int(angle[-1] // (2 * np.pi)) + 1)
            marks = marks[marks >= angle[0]]
            turns += marks.size
            stamp, log, keep = _rig_stamps(np.interp(marks, angle, t), rng)
            streams.append(_stamped("/rig/tacho", "std_msgs/msg/Header", stamp, log, {}))
            bag.write_streams(streams)
    simulated.unlink()
    mapping = path.with_suffix(".map.yaml")
    mapping.write_text(json.dumps({
        "channels": {name: {"topic": f"/rig/{name}", "field": "point.z"} for name in RIG},
        "shaft": {"source": "pulse", "topic": "/rig/tacho"},
        "unbalance": {"static": {"magnitude": 1.0e-2, "phase_deg": 0.0}}}))
    return path, simulated.with_suffix(".yaml"), mapping


def measure(path, mode: str) -> dict:
    """The comparison of ``path`` in a fresh process (``mode`` streamed or memory): its time_s,
    cpu_s, verdict and peak_mb."""
    args = [str(p) for p in (path if isinstance(path, tuple) else (path,))]
    out = subprocess.run([sys.executable, "-c", CHILD, args[0], mode, *args[1:]],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def measured(path, modes, repeats: int) -> dict:
    """``{mode: measure's report}`` over ``repeats`` interleaved rounds: the best CPU and wall
    time, the largest peak."""
    runs = {}

    def run(mode):
        report = measure(path, mode)
        runs[mode] = {**report, "peak_mb": max(report["peak_mb"],
                                               runs.get(mode, report)["peak_mb"])}
        return report["cpu_s"], report["time_s"]
    best = interleaved({mode: mode for mode in modes}, repeats, measure=run)
    return {mode: {**runs[mode], "cpu_s": best[mode][0], "time_s": best[mode][1]}
            for mode in modes}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--long", action="store_true", help="2 s to 1 h")
    parser.add_argument("--lengths", type=float, nargs="+", help="run lengths in s")
    parser.add_argument("--runup", action="store_true", help="run-ups instead of a held speed")
    parser.add_argument("--mapped", action="store_true",
                        help="run-ups recorded as a rig's drivers would, compared via a mapping")
    parser.add_argument("--repeats", type=int, default=1, help="interleaved rounds (best of)")
    args = parser.parse_args()
    write = write_mapped if args.mapped else write_runup if args.runup else write_recording
    kind = "mapped run-up" if args.mapped else "run-up" if args.runup else "steady run"
    lengths = args.lengths or ([2.0, 120.0, 600.0, 3600.0] if args.long else [2.0, 10.0, 40.0])
    print(f"compare, {kind}: streamed vs in memory, best of {args.repeats} interleaved rounds; "
          f"{load_line()}")
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for length in lengths:
            path = write(Path(folder) / f"run_{length:g}s.mcap", length)
            bag = path[0] if isinstance(path, tuple) else path
            modes = ("streamed", "memory") if length <= IN_MEMORY_UP_TO_S else ("streamed",)
            report = measured(path, modes, args.repeats)
            row = {"length_s": length, "bag_mb": bag.stat().st_size / 2 ** 20,
                   "streamed": report["streamed"]}
            if "memory" in report:
                row["in_memory"] = report["memory"]
            bag.unlink()
            rows.append(row)
            s, m = row["streamed"], row.get("in_memory")
            ratio = (f"{s['peak_mb'] / m['peak_mb']:.2f} memory, "
                     f"{s['cpu_s'] / m['cpu_s']:.2f} CPU, {s['time_s'] / m['time_s']:.2f} wall"
                     if m else "baseline not run")
            print(f"{length:7g} s run ({row['bag_mb']:.1f} MB bag): streamed {s['peak_mb']:.0f} MB "
                  f"CPU {s['cpu_s']:.1f} s wall {s['time_s']:.1f} s [{s['verdict']}]"
                  + (f"; in-memory {m['peak_mb']:.0f} MB CPU {m['cpu_s']:.1f} s wall "
                     f"{m['time_s']:.1f} s [{m['verdict']}]" if m else "")
                  + f"; streamed/in-memory: {ratio}", flush=True)
    for first, last in zip(rows[:-1], rows[1:]):
        growth = [f"{mode} {(last[mode]['peak_mb'] - first[mode]['peak_mb']) / span:.3f}"
                  for mode in ("streamed", "in_memory") if mode in first and mode in last
                  for span in [last["length_s"] - first["length_s"]]]
        print(f"peak memory growth from {first['length_s']:g} to {last['length_s']:g} s of run, "
              f"MB per second of run: {', '.join(growth)}")
    row = [r for r in rows if "in_memory" in r][-1]
    s, m, length = row["streamed"], row["in_memory"], row["length_s"]
    result(f"compare, {kind}, streamed, {length:g} s run ({s['peak_mb']:.0f} MB)",
           s["cpu_s"] / length, s["time_s"] / length, "s of run",
           f"--in-memory ({m['peak_mb']:.0f} MB)", s["peak_mb"] / m["peak_mb"], "peak memory")
    return 0


if __name__ == "__main__":
    sys.exit(main())
