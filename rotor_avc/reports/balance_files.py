"""Files of `rotor-avc balance`: the balanced and unbalanced run-ups (npz, JSON), the ISO
21940-11 balance grades (``balance.json``) and the plots."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..output_files import save_figure, write_text, writing


def write_rigid_runs(path: Path, bal, ref, b_true, err, switch_times) -> Path:
    """The Zhou & Shi 2001 run-up balanced (``bal``) and not (``ref``) as ``balance.npz``."""
    with writing(path) as tmp:
        np.savez(tmp, t=bal.t, output_balanced=bal.output, output_unbalanced=ref.output,
                 position=bal.position, target=bal.target, mode=bal.mode.astype(str),
                 b_hat=bal.b_hat, b_true=b_true, rel_error=err, std=bal.std,
                 switch_times=np.array(switch_times))
    return path


def write_machine_runs(out: Path, rec, none, envelopes, unbalance, err, table) -> tuple[Path, Path]:
    """The machine's quasi-steady run-ups per strategy (``balance.npz``) and the per-resonance
    table (``resonances.json``)."""
    path = out / "balance.npz"
    with writing(path) as tmp:
        np.savez(tmp, t=rec.t, speed_rad_s=rec.speed, envelope_none=none,
                 **{f"envelope_{k}": v for k, v in envelopes.items()}, position=rec.position,
                 estimate=rec.estimate, unbalance=unbalance, rel_error=err, std=rec.std,
                 mode=rec.mode.astype(str))
    write_text(out / "resonances.json", json.dumps(table, indent=1))
    return path, out / "resonances.json"


def write_grades(out: Path, grades: dict, note: str) -> Path:
    """``balance.json``: the ISO 21940-11 grades of the true unbalance, the balancer's estimate
    and the residual after correction (:meth:`rotor_avc.balancing.grade.RotorGrade.balancer_grades`),
    with how the service speed was chosen."""
    return write_text(out / "balance.json", json.dumps({"iso21940_11": {
        "service_speed": note, **grades}}, indent=1) + "\n")


def plot_rigid_runs(path, bal, ref, err, switches) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    ax[0].plot(ref.t, np.abs(ref.output) * 1e3, lw=0.8, label="no balancing")
    ax[0].plot(bal.t, np.abs(bal.output) * 1e3, lw=0.8, label="balanced")
    ax[0].set_ylabel("|v| at output point [mm]")
    ax[1].semilogy(bal.t[1:], err[1:, 0] * 100, label="b1, b2 (force)")
    ax[1].semilogy(bal.t[1:], err[1:, 1] * 100, label="b3, b4 (moment)")
    ax[1].set_ylabel("estimate error [%]")
    ax[2].plot(bal.t, bal.position.real * 1e3, label="w_x")
    ax[2].plot(bal.t, bal.position.imag * 1e3, label="w_z")
    ax[2].set_ylabel("balancer position [mm]")
    ax[2].set_xlabel("time [s]")
    for a in ax:
        for t in switches:
            a.axvline(t, color="k", ls="--", lw=0.7)
        a.legend(loc="upper left", fontsize=8)
        a.grid(True, alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def plot_machine_runs(path, rec, none, envelopes, err) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    f_hz = rec.speed / (2 * np.pi)
    fig, ax = plt.subplots(2, 1, figsize=(9, 7))
    ax[0].semilogy(f_hz, none, lw=0.9, label="no balancing")
    for k, env in envelopes.items():
        ax[0].semilogy(f_hz, env, lw=0.8, label=k)
    ax[0].set_xlabel("rotational frequency [Hz]")
    ax[0].set_ylabel("max bearing-housing amplitude")
    ax[1].semilogy(rec.t, np.maximum(err[:, 0], 1e-8) * 100, label="static u_e")
    ax[1].semilogy(rec.t, np.maximum(err[:, 1], 1e-8) * 100, label="moment u_alpha")
    for t, _, _ in rec.events[:1]:
        ax[1].axvline(t, color="k", ls="--", lw=0.7)
    ax[1].set_xlabel("time [s]")
    ax[1].set_ylabel("estimate error [%]")
    for a in ax:
        a.legend(fontsize=8)
        a.grid(True, alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
