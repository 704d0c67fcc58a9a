"""Benchmark: peak memory and wall time of ``rotor-avc simulate`` to a bag against the simulated
duration -- the streamed path (``Scenario.run_blocks`` -> ``stream_run_bag``, the command's)
against the whole run held in memory and written at the end (``Scenario.run`` ->
``write_run_bag``) as the baseline, in the same run.

Run: ``python bench/bench_simulate_memory.py [--durations 2 20 200]``. Scenario: Werner 2021 case 3
steady (``scenario_case3_steady``, 5 kHz, 3 controllers). Every case runs in its own process;
its peak resident memory is the process's ``ru_maxrss`` (from ``os.wait4``).
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

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


def measure(folder: Path, duration_s: float, path: str) -> tuple[float, float]:
    """``(peak resident memory in MB, wall time in s)`` of one run in a fresh process."""
    cfg = folder / f"d{duration_s:g}.yaml"
    cfg.write_text(f"include: {ROOT / 'config' / 'scenario_case3_steady.yaml'}\n"
                   f"simulation: {{duration_s: {duration_s}}}\n")
    out = folder / f"{path}_{duration_s:g}.mcap"
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(cfg), str(out), path], env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if status != 0:
        raise SystemExit(f"the {path} run of {duration_s:g} s failed (status {status})")
    out.unlink()
    return usage.ru_maxrss / 1024, wall


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--durations", type=float, nargs="+", default=[2.0, 20.0, 60.0],
                    help="simulated seconds per case")
    args = ap.parse_args()
    print("simulate scenario_case3_steady to a bag (5 kHz): peak memory and wall time")
    print(f"  {'duration':>9}  {'streamed':>20}  {'in memory (baseline)':>22}  memory ratio")
    with tempfile.TemporaryDirectory() as tmp:
        for d in args.durations:
            m_s, t_s = measure(Path(tmp), d, "streamed")
            m_b, t_b = measure(Path(tmp), d, "baseline")
            print(f"  {d:8g} s  {m_s:8.0f} MB {t_s:8.1f} s  {m_b:10.0f} MB {t_b:8.1f} s  "
                  f"{m_s / m_b:10.2f}")


if __name__ == "__main__":
    main()
