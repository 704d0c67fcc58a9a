"""Benchmark: peak memory, CPU and wall time of ``rotor-avc simulate`` to a bag against the
simulated duration -- the streamed path (``Scenario.run_blocks`` -> ``stream_run_bag``, the
command's) against the whole run held in memory and written at the end (``Scenario.run`` ->
``write_run_bag``) as the baseline, the two interleaved in the same run.

Scenario: Werner 2021 case 3 steady (``scenario_case3_steady``, 5 kHz, 3 controllers). Every case
runs in its own process; its peak resident memory is the process's ``ru_maxrss`` (from
``os.wait4``, the largest of the repeats), its CPU time that of the process (imports included),
each the best of the repeats.

Run: ``python bench/bench_simulate_memory.py [--durations 2 20 60] [--repeats 1]``.
"""
import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from timing import interleaved, load_line, result

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import sys
from rotor_avc.recording import stream_run_bag, write_run_bag
from rotor_avc.scenario import load_scenario
sc = load_scenario(sys.argv[1])
if sys.argv[3] == "streamed":
    for _ in stream_run_bag(sys.argv[2], sc, sc.run_blocks(progress=False)):
        pass
else:
    write_run_bag(sys.argv[2], sc, sc.run(progress=False))
"""


def run_case(folder: Path, duration_s: float, path: str, peaks: dict) -> None:
    """One run in a fresh process; its peak resident memory (MB) raises ``peaks[path]``."""
    cfg = folder / f"d{duration_s:g}.yaml"
    cfg.write_text(f"include: {ROOT / 'config' / 'scenario_case3_steady.yaml'}\n"
                   f"simulation: {{duration_s: {duration_s}}}\n")
    out = folder / f"{path}_{duration_s:g}.mcap"
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(cfg), str(out), path], env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = status                     # reaped here: Popen must not wait again
    if status != 0:
        raise SystemExit(f"the {path} run of {duration_s:g} s failed (status {status})")
    out.unlink()
    peaks[path] = max(peaks.get(path, 0.0), usage.ru_maxrss / 1024)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--durations", type=float, nargs="+", default=[2.0, 20.0, 60.0],
                    help="simulated seconds per case")
    ap.add_argument("--repeats", type=int, default=1, help="interleaved rounds (best of)")
    args = ap.parse_args()
    print(f"simulate scenario_case3_steady to a bag (5 kHz): peak memory, CPU and wall time, best "
          f"of {args.repeats} interleaved rounds; {load_line()}")
    print(f"  {'duration':>9}  {'streamed':>28}  {'in memory (baseline)':>28}  memory ratio  "
          "CPU ratio")
    with tempfile.TemporaryDirectory() as tmp:
        for d in args.durations:
            peaks = {}
            best = interleaved({path: (lambda path=path: run_case(Path(tmp), d, path, peaks))
                                for path in ("streamed", "baseline")}, args.repeats)
            (c_s, t_s), (c_b, t_b) = best["streamed"], best["baseline"]
            m_s, m_b = peaks["streamed"], peaks["baseline"]
            print(f"  {d:8g} s  {m_s:6.0f} MB CPU {c_s:6.1f} s {t_s:6.1f} s  {m_b:6.0f} MB CPU "
                  f"{c_b:6.1f} s {t_b:6.1f} s  {m_s / m_b:12.2f}  {c_s / c_b:9.2f}")
        result(f"simulate case 3 to a bag, streamed, {d:g} s at 5 kHz ({m_s:.0f} MB)", c_s / d,
               t_s / d, "simulated s", f"whole run in memory ({m_b:.0f} MB)", m_s / m_b,
               "peak memory")


if __name__ == "__main__":
    main()
