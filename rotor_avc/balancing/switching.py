"""Optimal one-plane switching law of a rigid rotor during run-up (Zhou & Shi 2001 eqs. 7-13).

The cost of eq. (10) at time ``t`` is ``|u_b1 + u_s1| M_1(t) + l_s |u_b2 + u_s2| M_2(t)``: the
modal imbalance residuals of the translational (1) and conical (2) mode times their run-up
amplifications ``M_k = M_sk + M_nk`` (App. A, :mod:`.runup_response`). With ``u_b1 = x + iy``,
``u_b2 = d (y - ix)``, ``d = m w_y / I_t`` (eq. 9), the optimum lies on the line through the
imbalance (geometric argument, eqs. 11-12), and eq. (13) is piecewise linear in ``x``, so the law
is bang-bang: cancel mode 1 while ``M_1 > W M_2``, mode 2 while ``M_1 < W M_2`` (``M_2``
unscaled).

Switching weight: eq. (13) and the sentence after it give ``W = |d| l_s`` (``derived``: 2.68411 s
for the paper's rotor), but the paper's published switching time 2.9506 s is reproduced only by
``W = l_s`` (``paper``, the default). Both are offered; the discrepancy is the paper's.

Compensation targets (eqs. 4, 5) in the paper's balancer coordinates ``w = w_x + i w_z``:
``w = -(m_u/m_b)(u_x + i u_z)`` cancels the force imbalance (mode 1), ``w = -(m_u u_y /
(m_b w_y))(u_x + i u_z)`` the moment imbalance (mode 2).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from ..errors import ModelError
from ..models.rigid_rotor import RigidRotor
from .runup_response import runup_response, sudden_onset_time

WEIGHTS = ("paper", "derived")
STRATEGIES = ("none", "mode1", "mode2", "optimal")


def switching_weight(rotor: RigidRotor, balancer_axial_m: float, weight="paper") -> float:
    """``W`` of ``M_1 = W M_2``: ``paper`` -> ``l_s``, ``derived`` -> ``|d| l_s``, or a number."""
    l_s = abs(rotor.output_axial_m)
    if weight == "paper":
        return l_s
    if weight == "derived":
        return abs(rotor.d_coefficient(balancer_axial_m)) * l_s
    if isinstance(weight, bool) or not isinstance(weight, (int, float)) or not weight > 0:
        raise ModelError(f"switching weight must be 'paper', 'derived' or a number > 0 "
                         f"(got {weight!r})")
    return float(weight)


def mode_amplifications(rotor: RigidRotor, t, alpha: float, omega0: float = 0.0):
    """``(M_1(t), M_2(t))``, unit imbalance, ``M_2`` unscaled [rad/rad] (paper Figure 2)."""
    return tuple(runup_response(t, w, z, alpha, omega0).M
                 for w, z in zip(rotor.omega_n, rotor.zeta))


@dataclass(frozen=True)
class SwitchingSchedule:
    """The optimal mode over ``[0, t_end]``: mode at start and the switching instants."""

    weight: float
    start_mode: int
    #: (time [s], new mode, "root" or "jump" -- a sign change of M_1 - W M_2 at a t_K jump)
    switches: tuple[tuple[float, int, str], ...]

    def mode_at(self, t: float) -> int:
        mode = self.start_mode
        for t_sw, new, _ in self.switches:
            if t >= t_sw:
                mode = new
        return mode

    @property
    def times(self) -> list[float]:
        return [s[0] for s in self.switches]


def switching_schedule(rotor: RigidRotor, alpha: float, t_end: float, weight: float,
                       omega0: float = 0.0, grid_step_s: float = 1e-3) -> SwitchingSchedule:
    """Roots of ``g(t) = M_1(t) - W M_2(t)`` on ``[0, t_end]``: the switching instants of eq. (13).

    ``M_k`` jumps at the sudden-vibration onsets ``t_K``: ``g`` is searched on each continuous
    piece with brentq (tolerance 1e-9 s); a sign change across a jump is reported at ``t_K``."""
    if not (np.isfinite(t_end) and t_end > 0):
        raise ModelError(f"run-up duration must be > 0 (got {t_end})")
    if not weight > 0:
        raise ModelError(f"switching weight must be > 0 (got {weight})")

    def g(t):
        m1, m2 = mode_amplifications(rotor, t, alpha, omega0)
        return m1 - weight * m2

    jumps = sorted(tk for tk in (sudden_onset_time(w, z, alpha, omega0)
                                 for w, z in zip(rotor.omega_n, rotor.zeta)) if 0 < tk < t_end)
    edges = [0.0] + jumps + [t_end]
    eps = 1e-9
    switches = []
    g0 = g(np.array([0.0]))[0]
    mode = 1 if g0 >= 0 else 2
    start_mode = mode
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        lo = a + (eps if k > 0 else 0.0)
        hi = b - eps
        if k > 0:                              # across the jump at a = t_K
            new = 1 if g(np.array([lo]))[0] >= 0 else 2
            if new != mode:
                switches.append((a, new, "jump"))
                mode = new
        n = max(int(np.ceil((hi - lo) / grid_step_s)), 2)
        grid = np.linspace(lo, hi, n + 1)
        vals = g(grid)
        for i in np.nonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)[0]:
            root = brentq(lambda x: g(np.array([x]))[0], grid[i], grid[i + 1], xtol=1e-12)
            mode = 1 if vals[i + 1] > 0 else 2
            switches.append((float(root), mode, "root"))
    return SwitchingSchedule(float(weight), start_mode, tuple(switches))


def mode_target(mode: int, static_kg_m: complex, moment_kg_m2: complex,
                balancer_mass_kg: float, balancer_axial_m: float) -> complex:
    """Balancer position ``w_x + i w_z`` [m] cancelling mode ``mode`` (eqs. 4, 5; 0 = none).

    The imbalance is given as the LinearPlant excitation amplitudes of
    :mod:`rotor_avc.models.rigid_rotor`: ``static = m_u (u_x - j u_z)``, ``moment = m_u u_y (u_x -
    j u_z)``; a balancer at ``w`` adds ``m_b conj(w)`` and ``m_b w_y conj(w)``."""
    if mode == 0:
        return 0j
    if mode == 1:
        return -np.conj(static_kg_m) / balancer_mass_kg
    if mode == 2:
        if balancer_axial_m == 0:
            raise ModelError("a balancer in the plane of the mass centre (w_y = 0) cannot "
                             "correct the moment imbalance -- move the balancing plane")
        return -np.conj(moment_kg_m2) / (balancer_mass_kg * balancer_axial_m)
    raise ModelError(f"unknown balancing mode {mode} (0, 1 or 2)")


def eq13_minimiser(a: float, c: float, d: float, M1: float, M2: float) -> float:
    """``x`` minimising ``|a + x| M_1 + |c a + d x| M_2`` (eq. 13): ``-a`` if ``M_1 > |d| M_2``,
    else ``-c a / d`` (``M_2`` already scaled by ``l_s``)."""
    return -a if M1 > abs(d) * M2 else -c * a / d


class RigidSwitchingLaw:
    """The law the balancer block follows on the Zhou & Shi 2001 rotor (``decide``/``corrections``).

    ``strategy``: ``none`` (Figure 4(a)), ``mode1`` / ``mode2`` (single-mode balancing, 4(c),
    4(e)) or ``optimal`` (the switching schedule, 4(g))."""

    continuous = False

    def __init__(self, balancer_mass_kg: float, balancer_axial_m: float,
                 schedule: SwitchingSchedule, strategy: str = "optimal"):
        if strategy not in STRATEGIES:
            raise ModelError(f"unknown strategy {strategy!r}; use one of {STRATEGIES}")
        if not balancer_mass_kg > 0:
            raise ModelError(f"balancer mass must be > 0 (got {balancer_mass_kg})")
        self.balancer_mass_kg = balancer_mass_kg
        self.balancer_axial_m = balancer_axial_m
        self.schedule = schedule
        self.strategy = strategy

    def mode(self, t: float) -> int:
        """Mode balanced at ``t``: 0 none, 1 translational, 2 conical."""
        if self.strategy == "optimal":
            return self.schedule.mode_at(t)
        return STRATEGIES.index(self.strategy)

    def decide(self, t: float, speed: float, amplitudes: dict[str, complex]):
        k = self.mode(t)
        target = mode_target(k, amplitudes["static"], amplitudes["moment"],
                             self.balancer_mass_kg, self.balancer_axial_m)
        return ("none", "mode1", "mode2")[k], target

    def corrections(self, position: complex) -> dict[str, complex]:
        """Excitation amplitudes of a balancer at ``w = w_x + i w_z``: ``m_b conj(w)`` and
        ``m_b w_y conj(w)`` (:mod:`rotor_avc.models.rigid_rotor`)."""
        c = self.balancer_mass_kg * np.conj(position)
        return {"static": complex(c), "moment": complex(c * self.balancer_axial_m)}
