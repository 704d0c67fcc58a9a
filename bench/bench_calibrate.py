"""Benchmark: the time of a calibration fit against the number of fitted parameters and of
measured points, serial in this process and on 2 worker processes.

Data: bags this package writes of two machines whose parameters differ from the configured
ones, at 4 and at 8 stepped speeds (every recorded channel's 1x: 96 and 192 complex points for
the first): Werner 2021's case-3 machine (12 % stiffer actuators, foundation loss factor 0.055,
a 5 % lighter stator) and Werner 2019's motor on sleeve bearings with velocity feedback
(foundation loss factor 0.06, 10 % stiffer actuators); a model evaluation takes 10 to 30 ms,
the machine rebuilt from its configuration each time. Fits of 1 to 4
parameters, each the whole of :func:`rotor_avc.calibration.fit.calibrate` (screening Jacobian,
trust-region fit, Jacobian at the optimum), serial; on 2 workers as the study engine schedules
them (it measures the cost per column here and sends work to the workers only when a task is
worth about 0.1 s); and with every column sent to a worker (``batch_size=1``). Baseline, same
run, the arms interleaved (A B C D A B C D ...): one model evaluation at the configured values
(the unit of work: the serial fit's CPU time over it, against its evaluations, is the engine's
overhead) and the serial fit (the ratios); every parallel result is checked bit for bit against
the serial one (exit 1 on a difference). CPU time (this process and its finished children: the
workers) beside wall time, each the best of ``--repeats`` rounds (the machine is shared).
Measured here: a fit takes 0.2 to 1 s (16 to 100 evaluations); at 10 to 30 ms per evaluation the
engine keeps the columns in this process (wall ratio 0.8 to 1.0) and forcing them onto workers
costs 1.0 to 1.6 times the serial time: the workers pay off for models of about 0.1 s per
evaluation and more, or many starts.

Run: ``python bench/bench_calibrate.py [--repeats 3] [--machines NAME ...] [--speeds 4 8]
[--params 4] [--dwell-s 2]``.
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import copy  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from timing import interleaved, load_line, result  # noqa: E402
from rotor_avc.calibration.fit import calibrate  # noqa: E402
from rotor_avc.calibration.parameters import parameters  # noqa: E402
from rotor_avc.calibration.problem import Problem  # noqa: E402
from rotor_avc.calibration.targets import target_of  # noqa: E402
from rotor_avc.compare.comparison import compare_bag  # noqa: E402
from rotor_avc.config import find_config, load_yaml  # noqa: E402
from rotor_avc.machine import machine_from_config  # noqa: E402
from rotor_avc.recording import write_run_bag  # noqa: E402
from rotor_avc.scenario import scenario_from_config  # noqa: E402
from rotor_avc.studies.backends import ProcessBackend, SerialBackend  # noqa: E402

#: config -> (truth changes: path -> factor, or ("=", value); fitted paths; speeds per count;
#: unbalance)
MACHINES = {
    "foot_mount_case3": (
        {"elements.actuator.stiffness_n_per_m.z": 1.12, "foundation.tan_delta": ("=", 0.055),
         "machine.stator_mass_kg": 0.95},
        ["elements.actuator.stiffness_n_per_m.z", "foundation.tan_delta",
         "machine.stator_mass_kg", "foundation.mass_kg"],
        {4: [15.0, 40.0, 75.0, 110.0], 8: [8.0, 22.0, 35.0, 48.0, 60.0, 75.0, 95.0, 118.0]},
        {"static": {"magnitude": 1.0e-2, "phase_deg": 30.0}}),
    "sleeve_bearing_motor_velocity": (
        {"foundation.tan_delta": ("=", 0.06), "actuator.stiffness_n_per_m.z": 1.1},
        ["foundation.tan_delta", "actuator.stiffness_n_per_m.z", "motor.stator_mass_kg",
         "foundation.L.mass_kg"],
        {4: [10.0, 16.0, 22.0, 32.0], 8: [8.0, 12.0, 16.0, 19.0, 22.0, 26.0, 32.0, 40.0]},
        {"bent_rotor": {"magnitude": 1.0e-5, "phase_deg": 0.0}}),
}


def machine(name: str) -> dict:
    data = load_yaml(find_config(name))
    data.pop("simulation", None)
    return data


def recording(folder: Path, name: str, speeds, dwell_s: float) -> Path:
    truth = copy.deepcopy(machine(name))
    for path, change in MACHINES[name][0].items():
        *keys, last = path.split(".")
        node = truth
        for key in keys:
            node = node[key]
        node[last] = change[1] if isinstance(change, tuple) else node[last] * change
    sc = scenario_from_config({**truth, "simulation": {
        "sample_rate_hz": 5000.0, "initial_state": "steady_state",
        "unbalance": MACHINES[name][3],
        "speed": {"type": "stepped", "speeds_hz": speeds, "dwell_s": dwell_s,
                  "transition_s": 0.3}}}, "truth")
    path = folder / f"{name}_{len(speeds)}.mcap"
    write_run_bag(path, sc, sc.run(progress=False))
    return path


def problem(name: str, bag: Path, n_params: int) -> Problem:
    data = machine(name)
    comp = compare_bag(bag, machine=machine_from_config(data, "configured"))
    paths = MACHINES[name][1][:n_params]
    return Problem(data, "configured", parameters(data, [",".join(paths)]),
                   [target_of(comp, bag.name)])


def bench(prob: Problem, repeats: int) -> tuple[dict, dict]:
    """``(best {arm: (cpu_s, wall_s)}, {arm: its last result})`` of one evaluation, the serial
    fit, the fit as the engine schedules it on 2 workers and with every column on a worker."""
    z0 = prob.initial / prob.reference
    jobs = {"one": lambda: prob.scaled_residual(z0),
            "serial": lambda: calibrate(prob, SerialBackend()),
            "engine": lambda: calibrate(prob, ProcessBackend(2)),
            "columns": lambda: calibrate(prob, ProcessBackend(2), batch_size=1)}
    out = {}
    best = interleaved({arm: (lambda arm=arm: out.__setitem__(arm, jobs[arm]())) for arm in jobs},
                       repeats)
    return best, out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3, help="interleaved rounds (best of)")
    ap.add_argument("--machines", nargs="+", choices=list(MACHINES), default=list(MACHINES))
    ap.add_argument("--speeds", type=int, nargs="+", choices=[4, 8], default=[4, 8],
                    help="stepped speeds of the recordings")
    ap.add_argument("--params", type=int, choices=[1, 2, 3, 4], default=4,
                    help="fit 1 to this many parameters")
    ap.add_argument("--dwell-s", type=float, default=2.0, help="the recordings' dwell per speed")
    args = ap.parse_args()
    status = 0
    print(f"best of {args.repeats} interleaved rounds; {load_line()}")
    with tempfile.TemporaryDirectory() as tmp:
        print(f"{'machine':>30} {'points':>6} {'params':>6} {'eval ms':>8} {'evals':>6} "
              f"{'serial s':>9} {'cpu s':>6} {'engine s':>9} {'cpu s':>6} {'ratio':>6} "
              f"{'columns s':>10} {'cpu s':>6} {'ratio':>6}")
        for name in args.machines:
            for n_speeds in args.speeds:
                bag = recording(Path(tmp), name, MACHINES[name][2][n_speeds], args.dwell_s)
                for n_params in range(1, args.params + 1):
                    prob = problem(name, bag, n_params)
                    best, out = bench(prob, args.repeats)
                    same = all(np.array_equal(out["serial"].values, out[r].values)
                               for r in ("engine", "columns"))
                    status |= 0 if same else 1
                    (cpu_1, wall_1), (cpu, wall) = best["one"], best["serial"]
                    engine, cols = best["engine"], best["columns"]
                    evals = out["serial"].evaluations
                    print(f"{name:>30} {prob.points:6d} {n_params:6d} {1e3 * wall_1:8.1f} "
                          f"{evals:6d} {wall:9.2f} {cpu:6.2f} {engine[1]:9.2f} {engine[0]:6.2f} "
                          f"{engine[1] / wall:6.2f} {cols[1]:10.2f} {cols[0]:6.2f} "
                          f"{cols[1] / wall:6.2f}" + ("" if same else "  DIFFERENT RESULT"),
                          flush=True)
            what = f"calibrate {name}, {prob.points} points, {n_params} parameters"
            result(f"{what}, serial", cpu, wall, "fit", f"its {evals} model evaluations",
                   cpu / (evals * cpu_1))
            result(f"{what}, 2 workers as the engine schedules", engine[0], engine[1], "fit",
                   "the serial fit", engine[1] / wall, "wall")
    print("ratio: wall time on 2 workers over serial (< 1: the workers pay off); engine: as the "
          "study engine schedules; columns: every Jacobian column a task on a worker; evals: "
          "model evaluations of the serial fit; eval ms: one evaluation's wall time")
    return status


if __name__ == "__main__":
    sys.exit(main())
