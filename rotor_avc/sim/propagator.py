"""Exact one-sample propagators of a LinearPlant tabulated over rotor speed (DESIGN.md 2-3).

At a node speed ``Omega`` (damping frequency ``w_F`` from the :class:`DampingRule`), one matrix
exponential gives the ZOH step of :func:`rotor_avc.models.discretize.discretize_plant`, with one
rotating oscillator ``(c, s)``, ``c + j s = w e^{j Omega tau}``, per force basis vector ``p_b``::

    d/dt [x; u; c_b; s_b] = [[A, B P_a, B Re p_b, -B Im p_b], [0, 0, 0, 0], [0, 0, 0, -Omega],
                             [0, 0, Omega, 0]] [x; u; c_b; s_b]

    x_{k+1} = Phi x_k + Gamma_u u_k + sum_b (G_c,b Re w_b + G_s,b Im w_b)

exact for forces held over the sample and the rotating force ``Re{p_b w_b e^{j Omega tau}}``.
``w_b`` is the complex coefficient of ``p_b`` times the excitation's amplitude ``u`` and the shaft
phasor: ``(Omega^2 - j Omega') u`` for ``p2``, ``Omega u`` for ``p1``, ``u`` for ``p0``, times
the excitation's optional ``speed_factor`` (:mod:`rotor_avc.models.plant`). The exponential is
taken after diagonal balancing (``[q; q']`` mix units; balancing saves most squarings).

The measurement matrix ``R`` gives the rows of ``q``, ``q'`` and ``q'' = A_low x + M^-1 (P_a
u_{k-1} + f_e(t_k))`` from ``[x_k | u_{k-1} | w(t_k)]``; ``S = [Phi | Gamma_u | G_w]`` acts on
``[x_k | u_k | w_mid]``. Folded together, ``BIG`` maps
``[x_k | u_k | w_mid | w(t_k+1)]`` to ``[x_k+1 | y_k+1]``: one mat-vec per sample at constant
speed (the rotating excitation enters as input columns, not as a solve).

Between nodes both are interpolated linearly in ``Omega``. The nodes are placed (bisection) so
that the speed-dependent matrices ``D(w_F) + Omega G1`` and ``C + Omega/w_F N`` (+ speed terms)
deviate from their linear interpolation by at most ``rel_tol`` (Frobenius, relative) at every
interval midpoint. To first order in the deviation, the interpolated propagator is the exact
propagator of a plant whose damping and stiffness are off by that much -- e.g. for ``w_F = Omega``
the loss-factor damping ``D_eta/Omega`` needs a node spacing ``2 Omega sqrt(rel_tol)``. The
parts that are affine in ``Omega`` (gyroscopic matrix, rotating excitation) are exact along the
interval to first order but their chord errs at second order; :func:`max_node_spacing` caps the
node spacing for them (energy drift of an undamped gyroscopic rotor <= ``rel_tol`` per second).
Speeds held by the profile are nodes, so constant-speed runs are exact ZOH.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.linalg

from ..errors import ModelError
from ..resources import FLOAT_BYTES, check_memory
from ..models.discretize import continuous_state_space
from ..models.plant import LinearPlant
from ..settings import DAMPING_RULES



@dataclass(frozen=True)
class DampingRule:
    """``w_F`` of a run (DESIGN.md 2): ``speed`` -> ``max(Omega, floor)``; ``whirl`` -> frozen."""

    kind: str = "speed"
    whirl_rad_s: float | None = None

    def __post_init__(self):
        if self.kind not in DAMPING_RULES:
            raise ModelError(f"unknown damping rule {self.kind!r}; use one of {DAMPING_RULES}")
        if self.kind == "whirl" and not (self.whirl_rad_s is not None and self.whirl_rad_s > 0
                                         and np.isfinite(self.whirl_rad_s)):
            raise ModelError(f"damping at a whirl frequency needs whirl_rad_s > 0 "
                             f"(got {self.whirl_rad_s})")

    def w_F(self, plant: LinearPlant, speed) -> np.ndarray:
        if self.kind == "whirl":
            return np.full(np.shape(speed), float(self.whirl_rad_s))
        return plant.forced_damping_frequency(speed)

    def describe(self) -> str:
        return ("w_F = max(Omega, floor)" if self.kind == "speed"
                else f"w_F frozen at {self.whirl_rad_s:g} rad/s")


@dataclass(frozen=True)
class Basis:
    """A force basis vector ``p`` of excitation ``excitation`` (index) multiplied by
    ``Omega^power`` (with ``-j Omega'`` added for power 2) and the excitation's optional
    ``speed_factor(Omega)``."""

    excitation: int
    power: int
    vector: np.ndarray
    factor: Callable[[np.ndarray], np.ndarray] | None = None


def force_bases(plant: LinearPlant) -> list[Basis]:
    out = []
    for j, exc in enumerate(plant.excitations):
        for power, vec in ((2, exc.p2), (1, exc.p1), (0, exc.p0)):
            if vec is not None:
                out.append(Basis(j, power, np.asarray(vec, dtype=complex), exc.speed_factor))
    return out


def basis_coefficients(bases: list[Basis], speed, accel) -> np.ndarray:
    """Complex coefficients (shape ``speed.shape + (n_bases,)``) per unit amplitude, so that
    ``sum_b coef_b p_b = Excitation.phasor(speed, accel)`` for every excitation."""
    w = np.asarray(speed, dtype=float)
    a = np.asarray(accel, dtype=float)
    cols = []
    for b in bases:
        col = {2: w * w - 1j * a, 1: w + 0j, 0: np.ones(w.shape, complex)}[b.power]
        cols.append(col if b.factor is None else col * b.factor(w))
    return np.stack(cols, axis=-1) if cols else np.zeros(w.shape + (0,), complex)


class BufferLayout:
    """Column slices: ``S`` and ``R`` act on ``[x | u | w]`` (``cols``); the one-mat-vec step
    matrix ``BIG`` acts on ``[x_k | u_k | w_mid,k | w_meas,k+1]`` (``size``)."""

    def __init__(self, n_states: int, n_inputs: int, n_bases: int):
        N, m, nb = n_states, n_inputs, 2 * n_bases
        self.x = slice(0, N)
        self.u = slice(N, N + m)
        self.w = slice(N + m, N + m + nb)
        self.cols = N + m + nb
        self.w_next = slice(N + m + nb, N + m + 2 * nb)
        self.size = N + m + 2 * nb


def max_node_spacing(plant: LinearPlant, sample_period_s: float, rel_tol: float) -> float:
    """Widest node interval for the parts of the step that are *affine* in ``Omega``, whose
    linear interpolation still errs at second order (the chord of a rotation):

    * gyroscopic ``Omega G1``: the chord dissipates ``(h T g)^2 / 8`` of the energy per step
      (``g = ||M^-1/2 G1 M^-1/2||``), at most ``rel_tol`` per second of simulated time;
    * the rotating excitation ``e^{j Omega tau}``: relative force error ``(h T)^2 / 8 <= rel_tol``.
    """
    T = float(sample_period_s)
    widths = [np.sqrt(8.0 * rel_tol) / T]
    L = np.linalg.cholesky(plant.mass)
    g = np.linalg.norm(scipy.linalg.solve_triangular(
        L, scipy.linalg.solve_triangular(L, plant.gyroscopic, lower=True).T, lower=True), 2)
    if g > 0:
        widths.append(np.sqrt(8.0 * rel_tol / T) / g)
    return float(min(widths))


#: state-sized matrices the table keeps per speed node (propagators and their differences)
NODE_MATRICES = 4


def speed_nodes(plant: LinearPlant, rule: DampingRule, lo: float, hi: float, fixed,
                rel_tol: float, max_width: float = np.inf) -> np.ndarray:
    """Node speeds covering ``[lo, hi]`` (see the module docstring), including ``fixed``; no
    interval wider than ``max_width`` (:func:`max_node_spacing`)."""
    if not rel_tol > 0:
        raise ModelError(f"speed grid tolerance must be > 0 (got {rel_tol})")
    nodes = {float(lo), float(hi)} | {float(v) for v in fixed if lo <= v <= hi}
    floor = plant.damping_floor_rad_s
    if rule.kind == "speed" and lo < floor < hi:
        nodes.add(floor)                    # w_F = max(Omega, floor) has a kink there
    nodes = np.array(sorted(nodes))
    if nodes.size < 2:
        return nodes
    # the width cap first (uniform split of each interval), then bisection on curvature
    parts = np.maximum(1, np.ceil(np.diff(nodes) / max_width))
    n_states = 2 * len(plant.coords)
    check_memory(float(parts.sum()) * NODE_MATRICES * FLOAT_BYTES * n_states ** 2,
                 f"the simulation's speed grid of {parts.sum():.3g} nodes",
                 "check the units of the rotor's inertias and the speed range (the grid's spacing "
                 "follows the gyroscopic coupling)")
    parts = parts.astype(int)
    nodes = np.unique(np.concatenate([np.linspace(a, b, k + 1) for a, b, k
                                      in zip(nodes[:-1], nodes[1:], parts)]))
    min_width = 1e-9 * max(hi, 1.0)

    def mats(speed):
        w_F = rule.w_F(plant, speed)
        return plant.damping(speed, w_F), plant.stiffness_at(speed, w_F)

    for _ in range(64):
        a, b = nodes[:-1], nodes[1:]
        c = 0.5 * (a + b)
        bad = np.zeros(c.shape, bool)
        for Xa, Xb, Xc in zip(mats(a), mats(b), mats(c)):
            dev = np.linalg.norm(Xc - 0.5 * (Xa + Xb), axis=(1, 2))
            scale = np.linalg.norm(Xc, axis=(1, 2))
            bad |= dev > rel_tol * scale
        bad &= (b - a) > min_width
        if not bad.any():
            return nodes
        nodes = np.sort(np.concatenate([nodes, c[bad]]))
    raise ModelError("the speed grid did not converge (a speed-dependent term varies too "
                     "fast) -- raise the grid tolerance")


def expm_balanced(mat: np.ndarray) -> np.ndarray:
    """``expm(mat)`` after a diagonal similarity balancing: ``[q; q']`` have different units,
    and balancing cuts the norm (and the squarings of scaling-and-squaring) by orders."""
    bal, (scale, _) = scipy.linalg.matrix_balance(mat, permute=False, separate=True)
    return scipy.linalg.expm(bal) * scale[:, None] / scale[None, :]


class PropagatorTable:
    """Per node (computed on demand) the step matrix ``BIG = [[S, 0], [R_x S + R_u, R_w]]``
    mapping ``[x_k | u_k | w_mid | w_meas,k+1]`` to ``[x_k+1 | y_k+1]``, and ``R_x`` (the
    measurement's state columns, for moving the measurement speed along an interval)."""

    def __init__(self, plant: LinearPlant, sample_period_s: float, rule: DampingRule,
                 nodes: np.ndarray, meas_rows: np.ndarray, meas_orders: np.ndarray):
        self.plant = plant
        self.T = float(sample_period_s)
        self.rule = rule
        self.nodes = np.asarray(nodes, dtype=float)
        self.bases = force_bases(plant)
        n = plant.n
        self.P = np.array([a.force_vector for a in plant.actuators]).reshape(-1, n).T   # n x m
        self.layout = BufferLayout(2 * n, self.P.shape[1], len(self.bases))
        self.Pb = np.zeros((n, 2 * len(self.bases)))     # columns Re p_b, -Im p_b
        for i, b in enumerate(self.bases):
            self.Pb[:, 2 * i], self.Pb[:, 2 * i + 1] = b.vector.real, -b.vector.imag
        self.meas_rows = np.asarray(meas_rows, dtype=float)
        self.meas_orders = np.asarray(meas_orders, dtype=int)
        self._minv = np.linalg.inv(plant.mass)
        self.BIG: list[np.ndarray | None] = [None] * self.nodes.size
        self.Rx: list[np.ndarray | None] = [None] * self.nodes.size
        self.dRx: list[np.ndarray | None] = [None] * self.nodes.size     # Rx[i+1] - Rx[i]
        #: the run setup its nodes were placed for (set by rotor_avc.sim.stepper.PlantStepper)
        self.grid: tuple | None = None

    # -- exact matrices at one speed ---------------------------------------------------------
    def _continuous(self, speed: float):
        return continuous_state_space(self.plant, speed, float(self.rule.w_F(self.plant, speed)))

    def propagator(self, speed: float) -> np.ndarray:
        """``S = [Phi | Gamma_u | G_w]`` (N x cols) at one speed, exact."""
        lay, N = self.layout, self.layout.x.stop
        A, B = self._continuous(speed)
        aug = np.zeros((lay.cols, lay.cols))
        aug[:N, :N] = A
        aug[:N, lay.u] = B @ self.P
        aug[:N, lay.w] = B @ self.Pb
        for i in range(lay.w.start, lay.w.stop, 2):
            aug[i, i + 1], aug[i + 1, i] = -speed, speed
        return expm_balanced(aug * self.T)[:N]

    def measurement(self, speed: float) -> np.ndarray:
        """``R`` (rows x cols) at one speed: the rows of ``q``, ``q'`` and ``q'' = A_low x +
        M^-1 (P_a u_prev + Pb w_meas)`` by derivative order."""
        lay, n = self.layout, self.plant.n
        N = 2 * n
        A, _ = self._continuous(speed)
        kin = np.zeros((3 * n, lay.cols))
        kin[:N, lay.x] = np.eye(N)
        kin[N:, lay.x] = A[n:]
        kin[N:, lay.u] = self._minv @ self.P
        kin[N:, lay.w] = self._minv @ self.Pb
        R = np.zeros((len(self.meas_orders), lay.cols))
        for order in (0, 1, 2):
            sel = self.meas_orders == order
            R[sel] = self.meas_rows[sel] @ kin[order * n:(order + 1) * n]
        return R

    def step_matrix(self, S: np.ndarray, R: np.ndarray) -> np.ndarray:
        lay = self.layout
        N = lay.x.stop
        big = np.zeros((N + R.shape[0], lay.size))
        big[:N, :lay.cols] = S
        big[N:, :lay.cols] = R[:, lay.x] @ S
        big[N:, lay.u] += R[:, lay.u]
        big[N:, lay.w_next] = R[:, lay.w]
        return big

    # -- the table -----------------------------------------------------------------------------
    def ensure(self, indices, slopes=()) -> None:
        """Compute the nodes ``indices`` and the measurement slopes ``dRx`` of the intervals
        ``slopes`` (those not computed yet)."""
        slopes = np.unique(np.asarray(slopes, dtype=int))
        for i in np.unique(np.concatenate([np.asarray(indices, dtype=int), slopes, slopes + 1])):
            if self.BIG[i] is None:
                speed = float(self.nodes[i])
                R = self.measurement(speed)
                self.BIG[i] = self.step_matrix(self.propagator(speed), R)
                self.Rx[i] = np.ascontiguousarray(R[:, self.layout.x])
        for j in slopes:
            if self.dRx[j] is None:
                self.dRx[j] = self.Rx[j + 1] - self.Rx[j]

    def locate(self, speed) -> tuple[np.ndarray, np.ndarray]:
        """Node index ``i`` and weight ``w`` in ``[0, 1)`` with ``speed = (1-w) n_i + w n_i+1``;
        ``w`` is exactly 0 at a node."""
        s = np.asarray(speed, dtype=float)
        nodes = self.nodes
        lo, hi = nodes[0], nodes[-1]
        tol = 1e-12 * max(hi, 1.0)
        if np.any(s < lo - tol) or np.any(s > hi + tol):
            raise ModelError(f"speed outside the tabulated range [{lo:g}, {hi:g}] rad/s")
        if nodes.size == 1:
            return np.zeros(s.shape, int), np.zeros(s.shape)
        i = np.clip(np.searchsorted(nodes, s, side="right") - 1, 0, nodes.size - 2)
        w = np.clip((s - nodes[i]) / (nodes[i + 1] - nodes[i]), 0.0, 1.0)
        at_right = w >= 1.0
        i = np.where(at_right, i + 1, i)
        w = np.where(at_right, 0.0, w)
        return i, w

    def slope_interval(self, speed_a, speed_b) -> tuple[np.ndarray, np.ndarray]:
        """Interval ``j`` around the two speeds and ``(speed_b - speed_a) / width_j``: the
        weight change that carries ``R`` from ``speed_a`` to ``speed_b`` along interval ``j``."""
        a, b = np.asarray(speed_a, float), np.asarray(speed_b, float)
        if self.nodes.size == 1:
            return np.zeros(a.shape, int), np.zeros(a.shape)
        j = np.clip(np.searchsorted(self.nodes, 0.5 * (a + b), side="right") - 1, 0,
                    self.nodes.size - 2)
        return j, (b - a) / (self.nodes[j + 1] - self.nodes[j])
