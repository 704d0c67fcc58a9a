"""In-process run-up of the Zhou & Shi 2001 rotor with its one-plane balancer.

The plant is paper eq. (1) in complex form, ``R = R_X + i R_Z``, ``Theta = theta + i psi``,
``E(t) = (phi'^2 + i phi'') e^{-i phi}``, balancer at ``W = w_x + i w_z``::

    R''     + (2c/m) R'          + (2k/m) R          = [m_u (u_x + i u_z) + m_b W] / m  E
    Theta'' + (c L^2/2I_t) Theta' + (k L^2/2I_t) Theta (+ i (I_p/I_t)(phi'' Theta + phi' Theta'))
            = -i [m_u u_y (u_x + i u_z) + m_b w_y W] / I_t  E

integrated by classical RK4 with the balancer's actual (linearly moving) position at every stage,
from rest (zero state) with ``phi = phi0 + omega0 t + alpha t^2 / 2``. With ``dt = 5e-5 s`` it matches
the closed form of Appendix A to ~3e-6 of the peak (tests). The output is the spin-axis point at
``y = l_s``: ``v = R + i l_s Theta``, recorded noise-free.

Sampling contract (DESIGN.md 3): at ``t_k`` the estimator reads ``R_X, R_Z, theta, psi`` with
independent uniform noise of the stated amplitude (the paper: +-1e-5 m on the output; here
+-``noise_displacement_m`` on R_X, R_Z and +-``noise_tilt_rad`` on theta, psi), exact velocities, the accelerations of the plant equation at
``t_k`` (for the ``measured`` regression) and the balancer's actual position; the block's new
target starts a move at ``t_k``; the plant then advances to ``t_{k+1}``.
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from ..models.rigid_rotor import RigidRotor
from .actuator import BalancerActuator
from .regression import RigidSample


@dataclass(frozen=True)
class RigidRunup:
    """One run-up scenario of the Zhou & Shi 2001 rotor (SI units)."""

    rotor: RigidRotor
    accel_rad_s2: float
    duration_s: float
    sample_period_s: float
    integrator_step_s: float
    imbalance_mass_kg: float
    imbalance_position_m: tuple[float, float, float]   # (u_x, u_y, u_z) body frame
    balancer_mass_kg: float
    balancer_axial_m: float                            # w_y
    speed0_rad_s: float = 0.0
    angle0_rad: float = 0.0
    noise_displacement_m: float = 0.0                  # uniform +- on R_X and R_Z
    noise_tilt_rad: float = 0.0                        # uniform +- on theta and psi
    seed: int = 0

    def __post_init__(self):
        for name in ("accel_rad_s2", "duration_s", "sample_period_s", "integrator_step_s",
                     "balancer_mass_kg"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ModelError(f"run-up {name} must be > 0 (got {value})")
        if self.speed0_rad_s < 0 or self.noise_displacement_m < 0 or self.noise_tilt_rad < 0:
            raise ModelError("run-up initial speed and noise levels must be >= 0")
        ratio = self.sample_period_s / self.integrator_step_s
        if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
            raise ModelError(f"sample period {self.sample_period_s} s must be a whole multiple "
                             f"of the integrator step {self.integrator_step_s} s")

    @property
    def top_speed_rad_s(self) -> float:
        """The speed at the end of the run (the highest)."""
        return self.speed0_rad_s + self.accel_rad_s2 * self.duration_s

    @property
    def n_samples(self) -> int:
        return int(round(self.duration_s / self.sample_period_s)) + 1

    def true_amplitudes(self) -> dict[str, complex]:
        """The imbalance as LinearPlant amplitudes (``static``, ``moment``; models/rigid_rotor)."""
        ux, uy, uz = self.imbalance_position_m
        s = self.imbalance_mass_kg * complex(ux, -uz)
        return {"static": s, "moment": s * uy}

    def true_b(self) -> np.ndarray:
        """``[b1, b2, b3, b4]`` of paper eq. (2)."""
        ux, uy, uz = self.imbalance_position_m
        k = self.imbalance_mass_kg / self.rotor.mass_kg
        return k * np.array([ux, uz, ux * uy, uz * uy])


@dataclass
class RigidRunupRecord:
    """Time series of one run (one row per sample)."""

    t: np.ndarray
    output: np.ndarray            # v = X + i Z of the output point, noise-free [m]
    position: np.ndarray          # actual balancer position w_x + i w_z [m]
    target: np.ndarray
    mode: np.ndarray              # block mode per sample ("" without a block)
    b_hat: np.ndarray             # (N, 4) estimate of b1..b4 (NaN without a block)
    std: np.ndarray               # (N, 2) std of the static / moment amplitude estimates
    events: list = field(default_factory=list)   # (time, mode, target) of commanded moves

    def peak(self, t_from: float = -math.inf, t_to: float = math.inf) -> tuple[float, float]:
        """``(max |v|, time)`` over ``t_from <= t < t_to``."""
        sel = (self.t >= t_from) & (self.t < t_to)
        k = np.argmax(np.abs(self.output[sel]))
        return float(np.abs(self.output[sel][k])), float(self.t[sel][k])

    @property
    def rms(self) -> float:
        return float(np.sqrt(np.mean(np.abs(self.output) ** 2)))


def simulate_rigid_runup(sc: RigidRunup, block=None,
                         actuator: BalancerActuator | None = None) -> RigidRunupRecord:
    """Run the scenario with ``block`` (a :class:`.block.BalancerBlock` or None: balancer fixed
    at the actuator's initial position) moving ``actuator`` (default: paper, 0.2 s moves)."""
    rot = sc.rotor
    actuator = actuator or BalancerActuator(move_time_s=0.2)
    actuator.reset()
    if block is not None:
        block.reset()
    (k1, k2), (z1, z2) = rot.omega_n ** 2, rot.zeta
    c1, c2 = 2 * z1 * rot.omega_n[0], 2 * z2 * rot.omega_n[1]
    g2 = rot.I_p / rot.I_t if rot.gyroscopic else 0.0
    m, I_t, mb, wy = rot.mass_kg, rot.I_t, sc.balancer_mass_kg, sc.balancer_axial_m
    ux, uy, uz = sc.imbalance_position_m
    U1 = sc.imbalance_mass_kg * complex(ux, uz) / m
    U2 = -1j * sc.imbalance_mass_kg * uy * complex(ux, uz) / I_t
    B1, B2 = mb / m, -1j * mb * wy / I_t
    alpha, w0, p0 = sc.accel_rad_s2, sc.speed0_rad_s, sc.angle0_rad
    l_s = rot.output_axial_m

    def accel(t, R, dR, Th, dTh, W):
        om = w0 + alpha * t
        E = complex(om * om, alpha) * cmath.exp(-1j * (p0 + w0 * t + 0.5 * alpha * t * t))
        ddR = (U1 + B1 * W) * E - c1 * dR - k1 * R
        ddTh = (U2 + B2 * W) * E - c2 * dTh - k2 * Th
        if g2:
            ddTh -= 1j * g2 * (alpha * Th + om * dTh)
        return ddR, ddTh

    N = sc.n_samples
    T = sc.sample_period_s
    n_sub = int(round(T / sc.integrator_step_s))
    h = T / n_sub
    rng = np.random.default_rng(sc.seed)
    noise_R = (rng.uniform(-1, 1, N) + 1j * rng.uniform(-1, 1, N)) * sc.noise_displacement_m
    noise_th = (rng.uniform(-1, 1, N) + 1j * rng.uniform(-1, 1, N)) * sc.noise_tilt_rad
    out = np.zeros(N, complex)
    pos = np.zeros(N, complex)
    tgt = np.zeros(N, complex)
    modes = np.empty(N, dtype=object)
    b_hat = np.full((N, 4), np.nan)
    std = np.full((N, 2), np.nan)
    R = dR = Th = dTh = 0j
    for k in range(N):
        t = k * T
        W = actuator.position(t)
        out[k] = R + 1j * l_s * Th
        pos[k] = W
        if block is not None:
            ddR, ddTh = accel(t, R, dR, Th, dTh, W)
            om = w0 + alpha * t
            Rm, Tm = R + noise_R[k], Th + noise_th[k]
            sample = RigidSample(
                t=t, angle=p0 + w0 * t + 0.5 * alpha * t * t, speed=om, accel=alpha,
                R_X=Rm.real, dR_X=dR.real, theta=Tm.real, dtheta=dTh.real, R_Z=Rm.imag,
                dR_Z=dR.imag, psi=Tm.imag, dpsi=dTh.imag, w_x=W.real, w_z=W.imag,
                ddR_X=ddR.real, ddtheta=ddTh.real, ddR_Z=ddR.imag, ddpsi=ddTh.imag)
            res = block.step(sample)
            if res.new_move:
                actuator.command(res.target, t)
            modes[k] = res.mode
            b_hat[k] = block.estimator.b
            std[k] = (res.std["static"], res.std["moment"])
        else:
            modes[k] = ""
        tgt[k] = actuator.target
        for i in range(n_sub):
            ta = t + i * h
            Wa, Wm, We = actuator.position(ta), actuator.position(ta + h / 2), actuator.position(ta + h)
            a1R, a1T = accel(ta, R, dR, Th, dTh, Wa)
            R2, dR2, T2, dT2 = R + h / 2 * dR, dR + h / 2 * a1R, Th + h / 2 * dTh, dTh + h / 2 * a1T
            a2R, a2T = accel(ta + h / 2, R2, dR2, T2, dT2, Wm)
            R3, dR3, T3, dT3 = R + h / 2 * dR2, dR + h / 2 * a2R, Th + h / 2 * dT2, dTh + h / 2 * a2T
            a3R, a3T = accel(ta + h / 2, R3, dR3, T3, dT3, Wm)
            R4, dR4, T4, dT4 = R + h * dR3, dR + h * a3R, Th + h * dT3, dTh + h * a3T
            a4R, a4T = accel(ta + h, R4, dR4, T4, dT4, We)
            R += h / 6 * (dR + 2 * dR2 + 2 * dR3 + dR4)
            dR += h / 6 * (a1R + 2 * a2R + 2 * a3R + a4R)
            Th += h / 6 * (dTh + 2 * dT2 + 2 * dT3 + dT4)
            dTh += h / 6 * (a1T + 2 * a2T + 2 * a3T + a4T)
    events = list(block.events) if block is not None else []
    return RigidRunupRecord(np.arange(N) * T, out, pos, tgt, modes, b_hat, std, events)
