"""Benchmark: the unbalance FRF over speed of the Werner 2021 machine, loops open (case 2) and
closed (case 3), 2,000 speeds 1..250 Hz.

Ours: ``unbalance_frf`` (every output and actuator force, both excitations), which takes the modal
route here (rotor_avc.closed_loop.modal_frf: one eigendecomposition of the linearised dynamic
stiffness serves every speed). Arms, interleaved in one run, on the same speeds:

* baseline: the batched solve -- every speed's dynamic stiffness ``Z(j Omega)`` stacked into one
  (speeds, n, n) array, one ``numpy.linalg.solve`` for ``Z q = F``, and the same responses from
  ``q`` (goal: equal to 1e-9, each response relative to its own peak);
* the modal floor: ``ModalStiffness`` -- the eigendecomposition and the modal sum for the
  coordinates ``q`` alone, nothing else (goal: ours within 2x, CPU).

python-control's ``frequency_response`` of the loop's state space, rebuilt at every speed
(D = D_eta / Omega and G = Omega G1 change with speed), checks one response on 1 speed in 100
(goal: equal to 1e-9); it is not timed.

Run: ``python bench/bench_frf.py [--speeds 2000] [--repeats 10]``; each figure is the best of the
repeats (exit status 1 when a goal is missed).
"""
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")    # small matrices: threads only contend

import argparse  # noqa: E402
import sys  # noqa: E402

import control  # noqa: E402
import numpy as np  # noqa: E402

from timing import interleaved, load_line, result  # noqa: E402
from rotor_avc.closed_loop.frf import unbalance_frf  # noqa: E402
from rotor_avc.closed_loop.modal_frf import ModalStiffness  # noqa: E402
from rotor_avc.machine import load_machine  # noqa: E402

CONFIGS = {"foot_mount_case2": "loops open", "foot_mount_case3": "closed loop"}


def python_control(loop, speeds):
    """``bearing_D_vz`` to the static unbalance from python-control, rebuilt at every speed."""
    plant = loop.plant
    out = plant.output("bearing_D_vz")
    P = plant.excitation("static").p2
    n = plant.n
    response = np.empty(len(speeds), complex)
    for i, w in enumerate(speeds):
        A, B = loop.state_space(w, w)
        C = np.zeros((1, A.shape[0]))
        C[0, n:2 * n] = out.row                      # velocity output
        force = B @ P * w**2                          # complex: real and imaginary input
        sys_ = control.ss(A, np.column_stack([force.real, force.imag]), C, np.zeros((1, 2)))
        h = np.squeeze(control.frequency_response(sys_, [w]).complex)
        response[i] = h[0] + 1j * h[1]
    return response


def batched_solve(loop, speeds, excitations):
    """The responses of ``unbalance_frf`` from one batched solve (the baseline)."""
    plant = loop.plant
    F = np.stack([e.phasor(speeds) for e in excitations], axis=-1)
    Q = np.linalg.solve(loop.dynamic_stiffness(1j * speeds, speeds, speeds), F)
    names, rows, orders = plant.output_rows()
    out = (rows @ Q) * (1j * speeds[:, None, None]) ** orders[None, :, None]
    ref = {f"{name}_{e.name}": out[:, k, j] for k, name in enumerate(names)
           for j, e in enumerate(excitations)}
    for act_id, row in loop.force_rows(1j * speeds).items():
        for j, e in enumerate(excitations):
            ref[f"actuator_{act_id}_fz_{e.name}"] = np.einsum("Nn,Nn->N", row, Q[:, :, j])
    return ref


def modal_floor(loop, speeds, excitations):
    F = np.stack([e.phasor(speeds) for e in excitations], axis=-1)
    return ModalStiffness.of(loop).solve(speeds, F)


def peak_relative_error(ours, ref):
    """Largest ``max |a - b| / max |b|`` over the responses that are not zero by symmetry."""
    top = max(np.abs(v).max() for v in ref.values())
    return max(np.abs(ours[k] - v).max() / np.abs(v).max() for k, v in ref.items()
               if np.abs(v).max() > 1e-9 * top)


def bench(config, speeds, repeats) -> bool:
    loop = load_machine(config).loop
    excs = loop.plant.excitations
    out = {}
    arms = {"ours": lambda: out.__setitem__("ours", unbalance_frf(loop, speeds)),
            "solve": lambda: out.__setitem__("solve", batched_solve(loop, speeds, excs)),
            "floor": lambda: modal_floor(loop, speeds, excs)}
    for arm in arms.values():                        # warm-up: caches, allocator
        arm()
    best = interleaved(arms, repeats)
    frf = out["ours"]
    err = peak_relative_error(frf.responses, out["solve"])
    every = 100
    pc = python_control(loop, speeds[::every])
    err_pc = (np.max(np.abs(frf.responses["bearing_D_vz_static"][::every] - pc))
              / np.max(np.abs(pc)))
    n = len(speeds)
    (cpu, wall), (cpu_s, wall_s), (cpu_f, wall_f) = best["ours"], best["solve"], best["floor"]
    print(f"{config} ({CONFIGS[config]}), {n} speeds, {len(frf.responses)} responses; "
          "CPU (wall) ms")
    print(f"  ours: unbalance_frf (modal route)        {cpu * 1e3:8.2f} ({wall * 1e3:8.2f})")
    print(f"  baseline: batched solve, same responses  {cpu_s * 1e3:8.2f} ({wall_s * 1e3:8.2f})"
          f"   ours / baseline {cpu / cpu_s:5.3f} x (CPU)")
    print(f"  modal floor (decomposition + q alone)    {cpu_f * 1e3:8.2f} ({wall_f * 1e3:8.2f})"
          f"   ours / floor {cpu / cpu_f:5.2f} x (CPU; goal <= 2 x)")
    print(f"  max difference to the batched solve {err:.2e}, to python-control ({len(pc)} "
          f"speeds) {err_pc:.2e} (goal <= 1e-9, relative to each response's peak)")
    what = f"unbalance FRF, {config} ({CONFIGS[config]}), {n} speeds"
    result(what, cpu / n, wall / n, "speed", "batched numpy.linalg.solve", cpu / cpu_s)
    result(what, cpu / n, wall / n, "speed", "modal floor (ModalStiffness, q only)",
           cpu / cpu_f)
    return err <= 1e-9 and err_pc <= 1e-9 and cpu / cpu_f <= 2


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--speeds", type=int, default=2000,
                    help="speeds 1..250 Hz (at least 200: below, unbalance_frf takes the solve)")
    ap.add_argument("--repeats", type=int, default=10, help="interleaved rounds (best of)")
    args = ap.parse_args()
    speeds = 2 * np.pi * np.linspace(1.0, 250.0, args.speeds)
    print(f"best of {args.repeats} interleaved rounds; {load_line()}")
    ok = [bench(config, speeds, args.repeats) for config in CONFIGS]
    return 0 if all(ok) else 1


if __name__ == "__main__":
    sys.exit(main())
