"""Benchmark: 2,000-speed unbalance FRF of the Werner 2021 machine, loops open (case 2) and closed
(case 3).

Ours: ``unbalance_frf`` (every output and actuator force, both excitations), which takes the modal
route here (rotor_avc.closed_loop.modal_frf: one eigendecomposition of the linearised dynamic
stiffness serves every speed). Same run, on the same speeds:

* baseline: python-control's ``frequency_response`` on the loop's state space, rebuilt at every
  speed (D = D_eta / Omega and G = Omega G1 change with speed), one response (goal >= 100x);
* direct solve: the batched solve of ``Z(j Omega) q = F`` at every speed, every response
  (goal: equal to 1e-9, each response relative to its own peak);
* modal limit: the eigendecomposition and the modal sum for the coordinates ``q`` alone, nothing
  else (goal: ours within 2x).
"""
import os
import sys
import time

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")    # small matrices: threads only contend

import control  # noqa: E402
import numpy as np  # noqa: E402

from rotor_avc.closed_loop.frf import unbalance_frf  # noqa: E402
from rotor_avc.closed_loop.modal_frf import ModalStiffness  # noqa: E402
from rotor_avc.machine import load_machine  # noqa: E402


def python_control(loop, speeds):
    plant = loop.plant
    out = plant.output("bearing_D_vz")
    P = plant.excitation("static").p2
    n = plant.n
    result = np.empty(len(speeds), complex)
    for i, w in enumerate(speeds):
        A, B = loop.state_space(w, w)
        C = np.zeros((1, A.shape[0]))
        C[0, n:2 * n] = out.row                      # velocity output
        force = B @ P * w**2                          # complex: real and imaginary input
        sys_ = control.ss(A, np.column_stack([force.real, force.imag]), C, np.zeros((1, 2)))
        h = np.squeeze(control.frequency_response(sys_, [w]).complex)
        result[i] = h[0] + 1j * h[1]
    return result


def direct_solve(loop, speeds, excitations):
    """The responses of ``unbalance_frf`` from the batched solve (what the modal route replaces)."""
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


def modal_limit(loop, speeds, excitations):
    F = np.stack([e.phasor(speeds) for e in excitations], axis=-1)
    return ModalStiffness.of(loop).solve(speeds, F)


def timed(fn, reps):
    """Result and the fastest of ``reps`` runs (the least disturbed by other load)."""
    out, best = fn(), np.inf                         # warm-up
    for _ in range(reps):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def peak_relative_error(ours, ref):
    """Largest ``max |a - b| / max |b|`` over the responses that are not zero by symmetry."""
    top = max(np.abs(v).max() for v in ref.values())
    return max(np.abs(ours[k] - v).max() / np.abs(v).max() for k, v in ref.items()
               if np.abs(v).max() > 1e-9 * top)


def bench(config, speeds, reps=60):
    loop = load_machine(config).loop
    excs = loop.plant.excitations
    # the direct solve first: its large arrays make the allocator keep freed memory, so the
    # routes below are timed alike (else each call of the first one pays fresh page faults)
    ref, t_direct = timed(lambda: direct_solve(loop, speeds, excs), 3)
    frf, t_ours = timed(lambda: unbalance_frf(loop, speeds), reps)
    _, t_limit = timed(lambda: modal_limit(loop, speeds, excs), reps)
    every = 10                                       # python-control is slow: 1 in 10 speeds
    t0 = time.perf_counter()
    pc = python_control(loop, speeds[::every])
    t_pc = (time.perf_counter() - t0) * every
    err = peak_relative_error(frf.responses, ref)
    ours_one = frf.responses["bearing_D_vz_static"][::every]
    err_pc = np.max(np.abs(ours_one - pc)) / np.max(np.abs(pc))
    print(f"{config} ({'closed loop' if loop.controllers else 'loops open'}), {len(speeds)} speeds, "
          f"{len(frf.responses)} responses")
    print(f"  rotor_avc unbalance_frf (modal route): {t_ours * 1e3:8.2f} ms")
    print(f"  modal limit (decomposition + q)      : {t_limit * 1e3:8.2f} ms   ours / limit "
          f"{t_ours / t_limit:5.2f} x  (goal <= 2 x)")
    print(f"  batched direct solve                 : {t_direct * 1e3:8.2f} ms   speed-up "
          f"{t_direct / t_ours:6.1f} x")
    print(f"  python-control rebuilt per speed     : {t_pc * 1e3:8.1f} ms   speed-up "
          f"{t_pc / t_ours:6.1f} x  (goal >= 100 x; timed on {len(pc)} speeds, x{every})")
    print(f"  max difference to the direct solve   : {err:.2e}   to python-control {err_pc:.2e}  "
          "(goal <= 1e-9, relative to each response's peak)")
    ok = err <= 1e-9 and err_pc <= 1e-9 and t_pc / t_ours >= 100 and t_ours / t_limit <= 2
    return ok


def main(n_speeds: int = 2000) -> int:
    speeds = 2 * np.pi * np.linspace(1.0, 250.0, n_speeds)
    ok = [bench(config, speeds) for config in ("foot_mount_case2", "foot_mount_case3")]
    return 0 if all(ok) else 1


if __name__ == "__main__":
    sys.exit(main())
