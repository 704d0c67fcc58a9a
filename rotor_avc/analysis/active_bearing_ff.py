"""Quantified actuator force and phase of Sci. Rep. 2023: the synchronous feed-forward that cancels the
bearing-housing motion (eqs. 30-39).

At spin speed ``Omega`` the synchronous compliance (eqs. 30-31, with ``K'`` in ``kappa'`` where
the paper prints ``K``; taken in the original coordinates, whose housing rows equal those of
``q'``)::

    H(Omega) = (K - Omega^2 M + j Omega (C + Omega G1))^-1

maps force phasors to displacement phasors. With the unbalance phasor ``F_e = m_o e Omega^2 p2``
and the actuator forces ``F_a`` on the actuator masses (force vectors ``P``), the housing motion
``S H (F_e + P F_a)`` (rows ``S``: the actuators' housing rows) is cancelled by

* ``paper`` -- eqs. (38)-(39) with the sign corrected (the printed form doubles the housing
  motion): per bearing ``i``, ``F_i = -A_i^-1 b_i`` with ``A_i = S_i H P_i`` over its y and x
  actuators and ``b_i = [s_iy H F_e|y-plane, s_ix H F_e|x-plane]``: the paper keeps only the
  same-direction unbalance terms and drops the other bearing's actuators (eqs. 32-35);
* ``exact`` -- all four housings together (not in the paper): ``F_a = -(S H P)^-1 S H F_e``.

The forces depend on ``Omega`` only, not on the sensor choice; the physical actuator force is
``Re{F_a e^{j theta}}`` with the shaft angle ``theta`` (phase 0: the unbalance force along x).
Every plant output (housings, piezo elongations, shaft points through ``Pi``) follows before and
after control from the same ``H``; IL (eq. 43) per point is then an amplitude ratio.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..closed_loop.loop import ClosedLoop
from ..section import Section
from ..control.synchronous import SynchronousForceGenerator
from ..errors import ModelError
from ..models.active_bearing import COORDS, PLANES, plane_mask
from ..model_config.active_bearing import model_settings
from ..models.piezo import PiezoStack
from ..models.plant import LinearPlant
from ..settings import FEEDFORWARD_METHODS as METHODS
from .insertion_loss import first_sign_change, insertion_loss_db, phasor_rms



def feedforward_method(cfg: Section) -> str:
    """``feedforward.method`` of an active-bearing config (declared in
    rotor_avc.model_config.active_bearing; default ``paper``)."""
    return model_settings(cfg).feedforward.method


@dataclass(frozen=True, eq=False)
class FeedforwardResult:
    """Forces and responses over speed, per unit unbalance ``m_o e`` [kg m] and scaled by
    ``unbalance_kg_m`` in the properties (actuator and output order of the plant)."""

    plant: LinearPlant
    method: str
    speed_rad_s: np.ndarray          # (N,)
    unbalance_kg_m: complex
    forces_per_unit: np.ndarray      # (N, m) N per kg m
    unbalance_response: np.ndarray   # (N, k) output per kg m
    force_response: np.ndarray       # (N, k, m) output per N of each actuator

    @property
    def speed_hz(self) -> np.ndarray:
        return self.speed_rad_s / (2 * np.pi)

    @property
    def output_names(self) -> list[str]:
        return [o.name for o in self.plant.outputs]

    @property
    def actuator_ids(self) -> list[str]:
        return [a.id for a in self.plant.actuators]

    @property
    def forces(self) -> np.ndarray:
        """Actuator force phasors [N], shape (N, m)."""
        return self.forces_per_unit * self.unbalance_kg_m

    @property
    def before(self) -> np.ndarray:
        """Output phasors without control, shape (N, k)."""
        return self.unbalance_response * self.unbalance_kg_m

    def after(self, forces=None) -> np.ndarray:
        """Output phasors with the given actuator forces (default: the quantified ones)."""
        forces = self.forces if forces is None else np.asarray(forces)
        return self.before + np.einsum("Nkm,Nm->Nk", self.force_response, forces)

    def unbalance_force(self) -> np.ndarray:
        """Unbalance force phasor along each actuator's direction [N], shape (N, m)."""
        p2 = self.plant.excitation("unbalance").p2
        cols = [p2[COORDS.index(f"eps_r_{a.axis}")] for a in self.plant.actuators]
        return self.speed_rad_s[:, None] ** 2 * np.array(cols) * self.unbalance_kg_m

    def force_phase_deg(self, forces=None) -> np.ndarray:
        """Phase of each actuator force relative to the unbalance force in its direction
        (the paper's quantified phase), in (-180, 180] degrees."""
        forces = self.forces if forces is None else np.asarray(forces)
        return np.degrees(np.angle(forces / self.unbalance_force()))

    def outputs(self, prefix: str, plane: str | None = None) -> list[int]:
        """Indices of the outputs whose name starts with ``prefix`` (and ends with ``_<plane>``)."""
        return [k for k, n in enumerate(self.output_names)
                if n.startswith(prefix) and (plane is None or n.endswith(f"_{plane}"))]

    def insertion_loss_db(self, forces=None) -> np.ndarray:
        """IL (eq. 43) of every output, shape (N, k)."""
        return insertion_loss_db(self.before, self.after(forces))


def _check_speeds(speed_rad_s) -> np.ndarray:
    speeds = np.atleast_1d(np.asarray(speed_rad_s, dtype=float))
    if speeds.ndim != 1 or speeds.size == 0 or np.any(~np.isfinite(speeds)) or np.any(speeds <= 0):
        raise ModelError("feed-forward speeds must be a non-empty list of positive, finite speeds")
    return speeds


def compliance(plant: LinearPlant, speed_rad_s, freq_rad_s=None, sensor_transform=None) -> np.ndarray:
    """The compliance matrix ``H`` of eqs. (30)-(31) over speed, shape (N, n, n).

    ``freq_rad_s`` (default: ``speed_rad_s``, the synchronous response) is the excitation
    frequency, for an FRF at fixed spin. Rows: the original coordinates, or ``q'`` when the
    ``Pi`` of eq. (11) is given (``H' = kappa'^-1 = Pi^-1 H`` with ``K' = K Pi``); columns: the
    original force numbering, as eqs. (32)-(35) index them. Accelerance is ``-w^2 H``."""
    speeds = _check_speeds(speed_rad_s)
    freqs = speeds if freq_rad_s is None else np.broadcast_to(np.asarray(freq_rad_s, float), speeds.shape)
    Z = ClosedLoop(plant).dynamic_stiffness(1j * freqs, speeds, plant.forced_damping_frequency(freqs))
    H = np.linalg.inv(Z)
    return H if sensor_transform is None else np.linalg.solve(sensor_transform, H)


def solve_feedforward(plant: LinearPlant, speed_rad_s, method: str = "paper",
                      unbalance_kg_m: complex = 1.0) -> FeedforwardResult:
    """Quantified actuator forces and the responses before/after at each speed (module doc)."""
    if method not in METHODS:
        raise ModelError(f"unknown feed-forward method {method!r}; use one of {', '.join(METHODS)}")
    if plant.coords != COORDS:
        raise ModelError(f"{plant.name}: the quantified force needs the Sci. Rep. 2023 active-bearing "
                         "plant (model: active_bearing)")
    speeds = _check_speeds(speed_rad_s)
    acts = plant.actuators
    P = np.array([a.force_vector for a in acts]).T                      # (n, m)
    S = np.array([a.sensor_row for a in acts])                          # (m, n)
    F_e = plant.excitation("unbalance").phasor(speeds)                  # (N, n)
    F_planes = np.stack([F_e * plane_mask(d) for d in PLANES], axis=-1)  # (N, n, 2)
    H = compliance(plant, speeds)
    q_planes, q_act = H @ F_planes, H @ P                               # (N, n, 2), (N, n, m)
    A = S @ q_act                                                       # (N, m, m)
    b_planes = S @ q_planes                                             # (N, m, 2)
    try:
        if method == "exact":
            forces = -np.linalg.solve(A, b_planes.sum(axis=-1)[..., None])[..., 0]
        else:
            forces = np.zeros((speeds.size, len(acts)), complex)
            b = np.stack([b_planes[:, k, PLANES.index(a.axis)] for k, a in enumerate(acts)], axis=-1)
            for bearing in sorted({a.id[1:] for a in acts}):
                g = [k for k, a in enumerate(acts) if a.id[1:] == bearing]
                forces[:, g] = -np.linalg.solve(A[:, g][:, :, g], b[:, g, None])[..., 0]
    except np.linalg.LinAlgError:
        raise ModelError(f"{plant.name}: the actuators cannot move their housings at some speed "
                         "(singular actuator compliance) -- check k_ac and the masses") from None
    names, rows, orders = plant.output_rows()
    gain = (1j * speeds[:, None]) ** orders[None, :]                    # (N, k)
    q_e = q_planes.sum(axis=-1)
    return FeedforwardResult(
        plant=plant, method=method, speed_rad_s=speeds, unbalance_kg_m=complex(unbalance_kg_m),
        forces_per_unit=forces,
        unbalance_response=np.einsum("kn,Nn->Nk", rows, q_e) * gain,
        force_response=np.einsum("kn,Nnm->Nkm", rows, q_act) * gain[..., None])


def shaft_il_margin(plant: LinearPlant, method: str, planes=PLANES, piezo: PiezoStack | None = None,
                    unbalance_kg_m: float = 1.0):
    """``f(speeds) -> min IL`` over the shaft points of ``planes`` [dB] (for zero crossings);
    with ``piezo``, the forces are saturated first (which makes IL depend on the unbalance)."""
    def margin(speeds):
        res = solve_feedforward(plant, speeds, method, unbalance_kg_m)
        forces = None if piezo is None else saturated_forces(res, piezo)[1]
        idx = [k for d in planes for k in res.outputs("shaft_", d)]
        return res.insertion_loss_db(forces)[:, idx].min(axis=1)
    return margin


def il_zero_crossing(plant: LinearPlant, method: str, grid_rad_s, planes=PLANES,
                     piezo: PiezoStack | None = None, unbalance_kg_m: float = 1.0) -> float | None:
    """Lowest speed [rad/s] at which the IL of some shaft point of ``planes`` drops below 0 dB
    (the end of the paper's "good control" range, Fig. 7), optionally with the forces saturated
    by ``piezo``; None if it stays >= 0 on the grid."""
    return first_sign_change(shaft_il_margin(plant, method, planes, piezo, unbalance_kg_m),
                             _check_speeds(grid_rad_s))


def saturation_onset(plant: LinearPlant, method: str, piezo: PiezoStack, grid_rad_s,
                     unbalance_kg_m: float) -> float | None:
    """Lowest speed [rad/s] above which some actuator needs more force amplitude than the
    piezo's limit ``F_lim(Omega)``; None if it never does on the grid."""
    def headroom_db(speeds):
        res = solve_feedforward(plant, speeds, method, unbalance_kg_m)
        return insertion_loss_db(piezo.force_limit_n(speeds), np.abs(res.forces).max(axis=1))
    return first_sign_change(headroom_db, _check_speeds(grid_rad_s))


def saturated_forces(result: FeedforwardResult, piezo: PiezoStack) -> tuple[np.ndarray, np.ndarray]:
    """``(alpha, forces)``: the quantified forces scaled together into the piezo's limits."""
    alpha = piezo.saturation_scale(result.forces, result.speed_rad_s)
    return alpha, result.forces * alpha[:, None]


def side_table(result: FeedforwardResult, forces=None) -> dict[tuple[str, str], dict[str, np.ndarray]]:
    """Table 2/3 layout: per (side L/R, plane) the RMS averaged over that side's shaft points
    before and after control [m], and the IL of those averages [dB], each shape (N,)."""
    after = result.after(forces)
    table = {}
    for side in "LR":
        for d in PLANES:
            idx = result.outputs(f"shaft_{side}", d)
            rms_b = phasor_rms(result.before[:, idx]).mean(axis=1)
            rms_a = phasor_rms(after[:, idx]).mean(axis=1)
            table[(side, d)] = {"rms_before": rms_b, "rms_after": rms_a,
                                "il_db": insertion_loss_db(rms_b, rms_a)}
    return table


def synchronous_generator(plant: LinearPlant, sample_period_s: float, unbalance_kg_m: complex,
                          method: str = "paper", points: int = 400):
    """The 1x force generator of the run (rotor_avc.control.synchronous): the quantified forces
    per unit unbalance tabulated from 1 Hz up to 90 % of the Nyquist frequency, played for the
    run's (known) unbalance, with the hold compensation of sample period ``T``."""
    top = 0.9 * np.pi / sample_period_s
    table = solve_feedforward(plant, np.linspace(2 * np.pi, top, points), method, 1.0)
    return SynchronousForceGenerator(table.speed_rad_s, table.forces_per_unit, unbalance_kg_m,
                                     [a.id for a in plant.actuators],
                                     sample_period_s=sample_period_s)
