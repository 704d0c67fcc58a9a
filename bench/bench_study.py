"""Benchmark: the study engine on this machine -- parallel efficiency of local processes, the
1,000-point Monte-Carlo robustness study of the Werner 2021 case-3 closed loop, cost per point and
scaling with points and workers, and what that means for a 10^6-point study on a cluster.

* efficiency: a study whose points cost about 50 ms (the case-3 robustness point, its speed
  grid scaled to 50 ms), serial in-process against 2 worker processes, the arms interleaved
  (goal: >= 80 %). Baseline, same rounds: the same points as two halves on a bare
  ``multiprocessing`` pool against a plain loop -- the parallelism the machine offers right now
  (other users' load lowers both); the engine's efficiency relative to it is its own overhead,
  and so is the share of the CPU time spent on the points (serial CPU time / total, the
  workers' included);
* Monte-Carlo: 1,000 points, stiffnesses and masses +-10-20 % (normal, uniform, log-normal),
  each point: poles at 0 and 250 Hz (stability, margin) and the peak bearing responses over
  2,000 speeds, on every core (goal: <= 60 s);
* scaling: total time for 250 / 500 points on 2 workers, 250 points on 1 and 2, and the
  1,000-point study against the 250-point time, the four runs interleaved.

CPU time (this process and its finished children: the workers) beside wall time, each the best
of the rounds. Every parallel run is checked bit for bit against the serial outcomes of the same
points (exit 1 on a difference).

Run: ``python bench/bench_study.py [--points 1000] [--base 250] [--efficiency-points 80]
[--speeds 2000] [--repeats 3] [--scale-repeats 1]``.
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import multiprocessing  # noqa: E402

import numpy as np  # noqa: E402

from timing import interleaved, load_line, result  # noqa: E402
from rotor_avc.analysis.robustness import robustness_point  # noqa: E402
from rotor_avc.config import load_config  # noqa: E402
from rotor_avc.studies.backends import ProcessBackend, SerialBackend, available_cores  # noqa: E402
from rotor_avc.studies.engine import (MAX_TASKS, TASK_TARGET_S, StudySpec,  # noqa: E402
                                      evaluate_batch, run_study)
from rotor_avc.studies.points import Sample, parse_sample  # noqa: E402

SAMPLES = ("foundation.stiffness_n_per_m.z,foundation.stiffness_n_per_m.y*=normal(1, 0.15)",
           "elements.actuator.stiffness_n_per_m.z*=uniform(0.8, 1.2)",
           "machine.stator_mass_kg*=lognormal(0, 0.1)",
           "foundation.mass_kg*=normal(1, 0.2)")


def study(n: int, n_speeds: int) -> StudySpec:
    cfg = load_config("foot_mount_case3")
    sample = Sample([parse_sample(s) for s in SAMPLES], n, 2026, cfg)
    return StudySpec(sample, robustness_point(cfg, np.linspace(1.0, 250.0, n_speeds)))


def runs(arms: dict, repeats: int) -> tuple[dict, dict]:
    """``(best {name: (cpu_s, wall_s)}, {name: last StudyRun})`` of ``{name: (spec, backend)}``
    run interleaved."""
    out = {}
    best = interleaved({name: (lambda name=name: out.__setitem__(
        name, run_study(*arms[name], progress=False))) for name in arms}, repeats)
    return best, out


_BARE = {}


def _bare_half(indices):
    spec = _BARE["spec"]
    return evaluate_batch(spec, spec.evaluator.prepare(), indices)


def efficiencies(spec, repeats: int):
    """Best-of-``repeats`` ``(cpu_s, wall_s)``, interleaved (the load of other users changes in
    between): engine serial and on 2 workers; plain loop and two halves on a bare forked pool;
    and whether the engine's two runs agree."""
    _BARE["spec"] = spec
    n = len(spec.points)
    halves = [list(range(n // 2)), list(range(n // 2, n))]

    def pool():
        with multiprocessing.get_context("fork").Pool(2) as p:
            p.map(_bare_half, halves)
    out = {}
    best = interleaved({
        "serial": lambda: out.__setitem__("serial", run_study(spec, SerialBackend(),
                                                              progress=False)),
        "engine": lambda: out.__setitem__("engine", run_study(spec, ProcessBackend(2),
                                                              progress=False)),
        "loop": lambda: _bare_half(list(range(n))), "pool": pool}, repeats)
    return best, out["serial"].outcomes == out["engine"].outcomes


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=1000, help="Monte-Carlo points")
    ap.add_argument("--base", type=int, default=250,
                    help="the scaling runs' points (this many on 1 and 2 workers, twice as many "
                         "on 2)")
    ap.add_argument("--efficiency-points", type=int, default=80, help="points of ~50 ms each")
    ap.add_argument("--speeds", type=int, default=2000, help="speeds of a point's FRF")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved rounds (best of)")
    ap.add_argument("--scale-repeats", type=int, default=1,
                    help="interleaved rounds of the scaling runs (long: one by default)")
    args = ap.parse_args()
    status = 0
    print(f"{load_line()} at start")

    # cost of one point, serial (best of the repeats: the least disturbed), and a speed grid
    # for ~50 ms points
    n_cost = min(20, args.base)
    cpu, wall = runs({"serial": (study(n_cost, args.speeds), SerialBackend())},
                     args.repeats)[0]["serial"]
    cost = cpu / n_cost
    n_speeds = int(np.clip(round(args.speeds * 0.05 / cost), 100, 4000))
    print(f"case-3 robustness point, {args.speeds} speeds: CPU {cost * 1e3:.1f} ms, wall "
          f"{wall / n_cost * 1e3:.1f} ms serial (best of {args.repeats})")

    # parallel efficiency at 2 workers
    n_eff = args.efficiency_points
    best, same = efficiencies(study(n_eff, n_speeds), args.repeats)
    if not same:
        print("  MISMATCH: 2 workers differ from serial")
        status = 1
    (cpu_s, wall_s), (cpu_e, wall_e) = best["serial"], best["engine"]
    eff = wall_s / (2 * wall_e)
    bare = best["loop"][1] / (2 * best["pool"][1])
    print(f"efficiency, {n_eff} points of {wall_s / n_eff * 1e3:.0f} ms ({n_speeds} speeds), "
          f"best of {args.repeats} interleaved rounds:")
    print(f"  serial {wall_s:6.2f} s, 2 workers {wall_e:6.2f} s -> speed-up "
          f"{wall_s / wall_e:.2f}, efficiency {eff * 100:5.1f} %   (goal >= 80 %)")
    print(f"  baseline (bare pool, two halves): efficiency {bare * 100:5.1f} % -> the engine "
          f"reaches {eff / bare * 100:5.1f} % of what the machine offers now")
    print(f"  CPU time (independent of other users' load): serial {cpu_s:.2f} s, 2 workers "
          f"{cpu_e:.2f} s (this process + workers) -> {cpu_s / cpu_e * 100:5.1f} % of it is the "
          "points' work")
    result(f"study engine, 2 workers, {n_eff} points of ~50 ms", cpu_e / n_eff, wall_e / n_eff,
           "point", "serial in this process", wall_e / wall_s, "wall")

    # scaling with workers and points, and the Monte-Carlo study on every core
    cores = available_cores()
    base = args.base
    best, out = runs({"1 worker": (study(base, args.speeds), SerialBackend()),
                      "2 workers": (study(base, args.speeds), ProcessBackend(2)),
                      "2 workers, twice the points": (study(2 * base, args.speeds),
                                                      ProcessBackend(2)),
                      "Monte-Carlo": (study(args.points, args.speeds), ProcessBackend(cores))},
                     args.scale_repeats)
    print(f"scaling ({args.speeds} speeds per point; {cores} cores), best of "
          f"{args.scale_repeats} interleaved rounds, CPU (wall):")
    t_base = best["2 workers"][1]
    for name, n in (("1 worker", base), ("2 workers", base),
                    ("2 workers, twice the points", 2 * base)):
        cpu, wall = best[name]
        print(f"  {n:5d} points, {name[:9]:9}: {cpu:6.2f} s ({wall:6.2f} s), {wall / n * 1e3:.1f} "
              f"ms per point, x{wall / t_base:.2f} the {base}-point time on 2 workers")
    print(f"  {base} points: 1 -> 2 workers speed-up {best['1 worker'][1] / t_base:.2f}")
    serial = out["1 worker"].outcomes
    for name, run in out.items():
        n = min(base, len(run.outcomes))
        if run.outcomes[:n] != serial[:n]:
            print(f"  MISMATCH: the first {base} points of '{name}' differ from the serial run")
            status = 1
    mc = out["Monte-Carlo"]
    cpu_mc, t_mc = best["Monte-Carlo"]
    stable = sum(o.record["stable"] for o in mc.outcomes if o.record)
    print(f"Monte-Carlo, {args.points} points on {cores} workers: CPU {cpu_mc:.1f} s, wall "
          f"{t_mc:.1f} s (goal <= 60 s; x{t_mc / t_base:.2f} the {base}-point time), "
          f"{t_mc / args.points * 1e3:.1f} ms per point, {stable} stable, {len(mc.failed)} failed, "
          f"batches of {mc.batch_size}")
    result(f"Monte-Carlo robustness, case 3, {args.points} points on {cores} workers",
           cpu_mc / args.points, t_mc / args.points, "point",
           f"{base} points on 2 workers, per point", t_mc / args.points / (t_base / base), "wall")

    # a 10^6-point study on a cluster, from the CPU time per point
    batch = max(math.ceil(TASK_TARGET_S / cost), math.ceil(1e6 / MAX_TASKS))
    print(f"10^6 points at {cost * 1e3:.1f} ms: {math.ceil(1e6 / batch)} tasks of {batch} points "
          f"({batch * cost:.1f} s each); {1e6 * cost / 3600:.1f} core-hours; "
          + ", ".join(f"{w} workers ~{1e6 * cost / w / 60:.0f} min" for w in (16, 64, 256)))
    print(f"{load_line()} at the end")
    return status


if __name__ == "__main__":
    raise SystemExit(main())
