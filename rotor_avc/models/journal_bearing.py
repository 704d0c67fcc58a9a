"""Cylindrical (plain, 360 deg) journal bearing: Reynolds film, equilibrium, dynamic coefficients.

Werner 2019 needs the oil-film coefficients ``c_ij(Omega)``, ``d_ij(Omega)`` of its sleeve bearings
(paper Fig. 3, missing); the paper points to Lund & Thomsen (1978) and
Someya (2013) for them. This module computes them the way those references do.

**Film** (isoviscous, incompressible, aligned journal). With the journal centre at ``(X, Y)``
(fixed frame, in units of the radial clearance ``C``), ``theta`` measured from ``X`` in the
direction of rotation, ``H = h / C = 1 - X cos(theta) - Y sin(theta)``, ``zeta = z / L`` and
``P = p C^2 / (mu omega R^2)``, the Reynolds equation reads::

    d/dtheta(H^3 dP/dtheta) + (R/L)^2 d/dzeta(H^3 dP/dzeta) = 6 dH/dtheta + 12 dH/d(omega t)

It is discretised by finite volumes (cell-centred, conservative, so the discrete operator is a
symmetric M-matrix) on ``n_theta`` x ``n_z`` cells over the half width (mid-plane symmetry),
``P = 0`` at the bearing edges. Cavitation: Reynolds (Swift-Stieber) condition ``P >= 0`` with
zero pressure gradient at rupture, posed as the complementarity problem ``P >= 0``, ``K P - b >=
0``, ``P (K P - b) = 0`` and solved exactly by a primal-dual active-set iteration, started from the
solution on a coarser grid. The film starts at the position of maximum film thickness (``P = 0``
there: Raimondi & Boyd's full journal bearing), which the perturbations keep fixed in the shell.

**Static equilibrium.** The dimensionless solution depends on the eccentricity ratio ``eps`` and
``L/D`` only. The load ``W`` balances the film force ``F = mu omega R L (R/C)^2 Fbar(eps)``, i.e.
the Sommerfeld number ``S = (R/C)^2 mu N L D / W = 1 / (pi Fbar)`` (``N = omega / 2 pi``, as
tabulated by Raimondi & Boyd 1958), at the attitude angle ``phi`` between load and eccentricity
(ahead in the direction of rotation).

**Dynamic coefficients** (Lund's perturbation method): the linearised Reynolds equation for
small displacements and velocities of the journal, on the equilibrium's full-film region, gives
``K_ij = -dF_i/dx_j`` and ``D_ij = -dF_i/dx'_j`` (N/m, N s/m) in the *load frame*: index 0 = the
direction of the static load, index 1 = 90 deg ahead of it in the direction of rotation; the first
index is the force direction. ``K = mu omega R L (R/C)^2 / C * k`` and ``D = mu R L (R/C)^2 / C *
c`` with the dimensionless ``k``, ``c`` of :class:`FilmSolution`.

**Oil and temperature.** Kinematic viscosity from the ASTM D341 (Walther) rule through the
oil's viscosities at 40 and 100 degC, ``log10(log10(nu + 0.7)) = A - B log10(T)`` (nu in mm^2/s,
T in K); density ``rho_15 (1 - alpha (T - 15))``. The effective film temperature follows the
adiabatic heat balance of Raimondi & Boyd: all friction power ``P_f`` leaves with the oil,
``Delta T = P_f / (rho c_p (Q - Q_s / 2))`` (``Q`` the flow into the film, ``Q_s`` the side
leakage), ``T_eff = T_in + Delta T / 2``; friction torque on the journal ``mu omega R^3 L / C
* 2 pi / sqrt(1 - eps^2) + e W sin(phi) / 2`` (full-film shear). A fixed effective temperature can
be given instead.

:func:`dimensionless_table` tabulates the film solution over ``eps`` once per ``L/D`` and grid
(cached), like a bearing data book; :func:`coefficient_table` finds the operating point of every
speed from it and returns a :class:`CoefficientTable` that interpolates over speed.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.interpolate
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import ModelError

#: eccentricity ratios of the dimensionless table (the film is solved exactly at these)
TABLE_EPS_RANGE = (0.02, 0.97)
TABLE_POINTS = 32
_COARSEST_N_THETA = 24


# -- oil -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Oil:
    """A mineral oil given by its viscosity grade data (ASTM D341 / Walther rule, see module)."""

    nu40_mm2_s: float
    nu100_mm2_s: float
    density15_kg_m3: float
    expansion_per_k: float
    heat_capacity_j_kg_k: float

    def __post_init__(self):
        if not (0 < self.nu100_mm2_s < self.nu40_mm2_s):
            raise ModelError(f"oil viscosities must satisfy 0 < nu100 < nu40 (got nu40 = "
                             f"{self.nu40_mm2_s}, nu100 = {self.nu100_mm2_s} mm^2/s)")
        if self.density15_kg_m3 <= 0 or self.heat_capacity_j_kg_k <= 0:
            raise ModelError("oil density and heat capacity must be > 0")
        if not 0 <= self.expansion_per_k < 0.01:
            raise ModelError(f"oil thermal expansion {self.expansion_per_k} 1/K is implausible "
                             "(mineral oils: about 6.5e-4 1/K)")

    def _walther(self) -> tuple[float, float]:
        t1, t2 = math.log10(313.15), math.log10(373.15)
        w1 = math.log10(math.log10(self.nu40_mm2_s + 0.7))
        w2 = math.log10(math.log10(self.nu100_mm2_s + 0.7))
        b = (w1 - w2) / (t2 - t1)
        return w1 + b * t1, b

    def kinematic_viscosity_m2_s(self, temp_c):
        a, b = self._walther()
        nu_mm2_s = 10 ** (10 ** (a - b * np.log10(np.asarray(temp_c, float) + 273.15))) - 0.7
        return nu_mm2_s * 1e-6

    def density_kg_m3(self, temp_c):
        t = np.asarray(temp_c, float)
        return self.density15_kg_m3 * (1 - self.expansion_per_k * (t - 15.0))

    def dynamic_viscosity_pa_s(self, temp_c):
        return self.kinematic_viscosity_m2_s(temp_c) * self.density_kg_m3(temp_c)


@dataclass(frozen=True)
class JournalBearing:
    """Geometry of one plain cylindrical bearing and the grid of its film solution."""

    diameter_m: float
    length_m: float
    radial_clearance_m: float
    n_theta: int = 120
    n_z: int = 12

    def __post_init__(self):
        for name in ("diameter_m", "length_m", "radial_clearance_m"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ModelError(f"journal bearing {name} must be > 0 (got {value})")
        if self.radial_clearance_m >= 0.05 * self.diameter_m:
            raise ModelError(f"radial clearance {self.radial_clearance_m} m is not small against "
                             f"the diameter {self.diameter_m} m (thin-film theory needs C << R; "
                             "give the radial clearance, not a diameter)")
        _check_grid(self.n_theta, self.n_z)

    @property
    def ld_ratio(self) -> float:
        return self.length_m / self.diameter_m


def _check_grid(n_theta: int, n_z: int) -> None:
    if n_theta < _COARSEST_N_THETA or n_theta % 4 or n_z < 2:
        raise ModelError(f"film grid {n_theta} x {n_z}: need n_theta >= {_COARSEST_N_THETA}, a "
                         "multiple of 4, and n_z >= 2 cells over the half width")


# -- the film ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FilmSolution:
    """Dimensionless film solution at one eccentricity ratio (see the module docstring).

    ``force``: ``Fbar``; ``attitude_rad``: ``phi``; ``flow`` ``Q / (R C N L)`` into the film and
    ``side_flow`` ``Q_s / (R C N L)``; ``stiffness`` ``k`` and ``damping`` ``c`` (2 x 2, load frame,
    normalised by ``mu omega R L (R/C)^2 / C`` and ``mu R L (R/C)^2 / C``)."""

    eccentricity: float
    force: float
    attitude_rad: float
    flow: float
    side_flow: float
    stiffness: np.ndarray
    damping: np.ndarray
    pressure: np.ndarray

    @property
    def sommerfeld(self) -> float:
        """Raimondi-Boyd Sommerfeld number ``(R/C)^2 mu N / (W / (L D))``."""
        return 1.0 / (math.pi * self.force)


class _Grid:
    def __init__(self, n_theta: int, n_z: int, ld_ratio: float):
        self.nt, self.nz, self.ld_ratio = n_theta, n_z, ld_ratio
        self.dth, self.dz = 2 * math.pi / n_theta, 0.5 / n_z
        self.th_c = (np.arange(n_theta) + 0.5) * self.dth          # cell centres
        self.th_f = (np.arange(n_theta) + 1.0) * self.dth          # face between cell i, i+1
        self.rl2 = (0.5 / ld_ratio) ** 2                            # (R/L)^2
        self.groove = n_theta // 2 - 1                              # face at theta = pi (h max)
        idx = np.arange(n_theta * n_z).reshape(n_theta, n_z)
        nxt = np.roll(idx, -1, axis=0)
        self._rows = np.concatenate([idx.ravel(), nxt.ravel(), idx[:, :-1].ravel(),
                                     idx[:, 1:].ravel(), idx.ravel()])
        self._cols = np.concatenate([nxt.ravel(), idx.ravel(), idx[:, 1:].ravel(),
                                     idx[:, :-1].ravel(), idx.ravel()])

    def operator(self, hf3: np.ndarray, hc3: np.ndarray) -> sp.csc_matrix:
        """``K`` (= minus the discrete Reynolds operator) for face values ``hf3`` and cell
        values ``hc3`` of ``H^3`` (or of its derivative: ``K`` is linear in them)."""
        nt, nz = self.nt, self.nz
        g = np.repeat((hf3 * self.dz / self.dth)[:, None], nz, axis=1)
        g_dir = np.zeros_like(g)
        g_dir[self.groove] = 2 * g[self.groove]                 # P = 0 on the groove face
        g[self.groove] = 0.0
        gz = np.repeat((self.rl2 * hc3 * self.dth / self.dz)[:, None], nz - 1, axis=1)
        diag = g + np.roll(g, 1, axis=0) + g_dir + np.roll(g_dir, 1, axis=0)
        diag[:, :-1] += gz
        diag[:, 1:] += gz
        diag[:, -1] += 2 * self.rl2 * hc3 * self.dth / self.dz   # P = 0 at the bearing edge
        vals = np.concatenate([-g.ravel(), -g.ravel(), -gz.ravel(), -gz.ravel(), diag.ravel()])
        n = nt * nz
        return sp.csc_matrix((vals, (self._rows, self._cols)), shape=(n, n))

    def cells(self, values: np.ndarray) -> np.ndarray:
        return np.repeat(values[:, None], self.nz, axis=1).ravel()

    def integrate(self, P: np.ndarray) -> np.ndarray:
        """``-int int P (cos, sin) dtheta dzeta`` over the full width -> film force (2,)."""
        Pm = P.reshape(self.nt, self.nz).sum(axis=1)
        w = 2 * self.dth * self.dz
        return -w * np.array([Pm @ np.cos(self.th_c), Pm @ np.sin(self.th_c)])


def _active_set_solve(K: sp.csc_matrix, b: np.ndarray, film: np.ndarray):
    """Solve the complementarity problem P >= 0, K P - b >= 0, P (K P - b) = 0 (K an M-matrix)
    by primal-dual active sets from the start set ``film`` -> (P, film, LU of K on the film)."""
    for _ in range(10 * int(np.sqrt(b.size)) + 50):
        P = np.zeros_like(b)
        idx = np.flatnonzero(film)
        lu = spla.splu(K[idx][:, idx].tocsc())
        P[idx] = lu.solve(b[idx])
        new = np.where(film, P > 0, K @ P - b < 0)
        if np.array_equal(new, film):
            return P, film, lu
        film = new
    raise ModelError("the cavitation active-set iteration did not settle (numerical trouble in "
                     "the Reynolds solution; try another film grid)")


def _start_set(grid: _Grid, pos, vel) -> np.ndarray:
    """Full-film cells to start from: the converging film on the coarsest grid, else the solution
    on the grid half as fine (theta and z), mapped cell by cell."""
    nt_c, nz_c = grid.nt // 2, max(grid.nz // 2, 2)
    if nt_c < _COARSEST_N_THETA or nt_c % 2:
        return grid.cells(pos[0] * np.sin(grid.th_c) - pos[1] * np.cos(grid.th_c) < 0)
    coarse = _film(_Grid(nt_c, nz_c, grid.ld_ratio), pos, vel)[1].reshape(nt_c, nz_c)
    jz = np.minimum(((np.arange(grid.nz) + 0.5) / grid.nz * nz_c).astype(int), nz_c - 1)
    return coarse[np.arange(grid.nt) // 2][:, jz].ravel()


def _film(grid: _Grid, pos=(0.0, 0.0), vel=(0.0, 0.0)):
    """Film with the journal at ``pos = (X, Y)`` moving at ``vel = (X', Y')`` (per ``omega t``)
    -> (P, full-film set, LU of K on it, H at cells, H at faces)."""
    hc = 1 - pos[0] * np.cos(grid.th_c) - pos[1] * np.sin(grid.th_c)
    hf = 1 - pos[0] * np.cos(grid.th_f) - pos[1] * np.sin(grid.th_f)
    squeeze = -(vel[0] * np.cos(grid.th_c) + vel[1] * np.sin(grid.th_c))
    K = grid.operator(hf**3, hc**3)
    b = -grid.cells(6 * (hf - np.roll(hf, 1)) * grid.dz + 12 * squeeze * grid.dth * grid.dz)
    P, film, lu = _active_set_solve(K, b, _start_set(grid, pos, vel))
    return P, film, lu, hc, hf


def film_solution(eccentricity: float, ld_ratio: float, n_theta: int = 120,
                  n_z: int = 12) -> FilmSolution:
    """The dimensionless film at eccentricity ratio ``eccentricity`` (0 < eps < 1)."""
    eps = float(eccentricity)
    if not (np.isfinite(eps) and 0 < eps < 1):
        raise ModelError(f"eccentricity ratio must satisfy 0 < eps < 1 (got {eps}); eps >= 1 "
                         "means the journal touches the shell")
    if not (np.isfinite(ld_ratio) and ld_ratio > 0):
        raise ModelError(f"bearing length/diameter ratio must be > 0 (got {ld_ratio})")
    _check_grid(n_theta, n_z)
    grid = _Grid(n_theta, n_z, ld_ratio)
    P, film, lu, hc, hf = _film(grid, (eps, 0.0))
    force = grid.integrate(P)
    # Lund's perturbations on the equilibrium's full film (same LU): a displacement X (Y) changes
    # H by -cos (-sin) in the operator and the wedge term, a velocity X' (Y') the squeeze term
    idx = np.flatnonzero(film)
    dF_dx, dF_dv = np.zeros((2, 2)), np.zeros((2, 2))
    for j, trig in enumerate((np.cos, np.sin)):
        dhf, dhc = -trig(grid.th_f), -trig(grid.th_c)
        rhs_x = (-grid.cells(6 * (dhf - np.roll(dhf, 1)) * grid.dz)
                 - grid.operator(3 * hf**2 * dhf, 3 * hc**2 * dhc) @ P)
        rhs_v = -grid.cells(12 * dhc * grid.dth * grid.dz)
        for out, rhs in ((dF_dx, rhs_x), (dF_dv, rhs_v)):
            dP = np.zeros_like(P)
            dP[idx] = lu.solve(rhs[idx])
            out[:, j] = grid.integrate(dP)
    fbar = float(np.hypot(*force))
    u = -force / fbar                                            # load direction
    R = np.array([[u[0], u[1]], [-u[1], u[0]]])                  # fixed frame -> load frame
    # flow into the film across the groove face (Couette minus pressure flow back into the
    # groove), side leakage across both edges; both per R C N L
    g, Pm = grid.groove, P.reshape(grid.nt, grid.nz)
    flow = 4 * math.pi * grid.dz * np.sum(hf[g] / 2 - hf[g] ** 3 / 12 * Pm[g + 1] / (grid.dth / 2))
    side = math.pi / 3 * grid.rl2 * np.sum(hc**3 * Pm[:, -1] / (grid.dz / 2)) * grid.dth
    return FilmSolution(eps, fbar, float(math.atan2(-u[1], u[0])), float(flow), float(side),
                        -R @ dF_dx @ R.T, -R @ dF_dv @ R.T, Pm)


# -- data-book table over eccentricity -----------------------------------------------------------
@dataclass(frozen=True)
class DimensionlessTable:
    """Film solutions over ``eps`` (exact at the nodes) with cubic interpolants in between.

    Quantities that grow without bound as ``eps -> 1`` are interpolated times ``(1 - eps^2)^2``."""

    ld_ratio: float
    eps: np.ndarray
    _spline: scipy.interpolate.CubicSpline

    def __call__(self, eps) -> dict[str, np.ndarray]:
        eps = np.asarray(eps, float)
        v = self._spline(eps)
        w = 1.0 / (1 - eps**2) ** 2
        return {"force": np.exp(v[..., 0]) * eps * w, "attitude_rad": v[..., 1],
                "flow": v[..., 2], "side_flow": v[..., 3],
                "stiffness": v[..., 4:8].reshape(eps.shape + (2, 2)) * w[..., None, None],
                "damping": v[..., 8:12].reshape(eps.shape + (2, 2)) * w[..., None, None]}


def dimensionless_table(ld_ratio: float, n_theta: int = 120, n_z: int = 12) -> DimensionlessTable:
    """The film over ``TABLE_EPS_RANGE`` (nodes clustered towards eps = 1), cached per input."""
    return _cached_table(float(ld_ratio), int(n_theta), int(n_z))


@functools.lru_cache(maxsize=16)
def _cached_table(ld_ratio: float, n_theta: int, n_z: int) -> DimensionlessTable:
    lo, hi = TABLE_EPS_RANGE
    t = np.linspace(0.0, 1.0, TABLE_POINTS)
    eps = lo + (hi - lo) * np.sin(0.5 * np.pi * t)
    rows = []
    for e in eps:
        s = film_solution(e, ld_ratio, n_theta, n_z)
        w = (1 - e**2) ** 2
        head = [math.log(s.force * w / e), s.attitude_rad, s.flow, s.side_flow]
        rows.append(np.concatenate([head, (s.stiffness * w).ravel(), (s.damping * w).ravel()]))
    return DimensionlessTable(ld_ratio, eps, scipy.interpolate.CubicSpline(eps, np.array(rows)))


# -- operating points over speed -----------------------------------------------------------------
@dataclass(frozen=True)
class CoefficientTable:
    """Operating points and dynamic coefficients of one bearing over speed (load frame, SI).

    ``stiffness[k]``, ``damping[k]``: 2 x 2 ``K``, ``D`` at ``speed_rad_s[k]``; :meth:`at`
    interpolates them (cubic spline over speed) inside the tabulated range and refuses outside."""

    speed_rad_s: np.ndarray
    eccentricity: np.ndarray
    attitude_rad: np.ndarray
    temperature_c: np.ndarray
    viscosity_pa_s: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray

    @functools.cached_property
    def _spline(self):
        values = np.concatenate([self.stiffness.reshape(-1, 4), self.damping.reshape(-1, 4)], 1)
        return scipy.interpolate.CubicSpline(self.speed_rad_s, values)

    def at(self, speed_rad_s) -> tuple[np.ndarray, np.ndarray]:
        """``(K, D)`` of shape ``speed.shape + (2, 2)`` at any speeds inside the table."""
        speed = np.asarray(speed_rad_s, float)
        lo, hi = self.speed_rad_s[0], self.speed_rad_s[-1]
        inside = np.isfinite(speed) & (speed >= lo * (1 - 1e-12)) & (speed <= hi * (1 + 1e-12))
        if not np.all(inside):
            bad = speed[~inside].ravel()[0]
            raise ModelError(
                f"sleeve-bearing coefficients are tabulated for {lo * 30 / math.pi:.6g} .. "
                f"{hi * 30 / math.pi:.6g} rpm, asked for {bad * 30 / math.pi:.6g} rpm (a "
                "hydrodynamic film needs rotation) -- use a speed in that range or widen the "
                "bearing's speed_range_rpm")
        v = self._spline(speed)
        return v[..., :4].reshape(speed.shape + (2, 2)), v[..., 4:].reshape(speed.shape + (2, 2))


def coefficient_table(bearing: JournalBearing, oil: Oil, load_n: float, speeds_rad_s,
                      supply_temp_c: float,
                      effective_temp_c: float | None = None) -> CoefficientTable:
    """Static equilibrium and dynamic coefficients of ``bearing`` under the static load
    ``load_n`` at each speed (rad/s, ascending), with the adiabatic effective temperature from
    the oil supply temperature, or a fixed ``effective_temp_c`` (see the module docstring)."""
    speeds = np.asarray(speeds_rad_s, float)
    if speeds.ndim != 1 or speeds.size < 4 or np.any(np.diff(speeds) <= 0) or speeds[0] <= 0:
        raise ModelError("bearing table speeds must be at least 4 ascending speeds > 0")
    if not (np.isfinite(load_n) and load_n > 0):
        raise ModelError(f"static bearing load must be > 0 (got {load_n} N)")
    table = dimensionless_table(bearing.ld_ratio, bearing.n_theta, bearing.n_z)
    R, L, C = bearing.diameter_m / 2, bearing.length_m, bearing.radial_clearance_m
    scale = R * L * (R / C) ** 2                     # F = mu omega scale Fbar
    rho = oil.density_kg_m3(supply_temp_c)
    w = speeds[:, None]

    def operating(eps):
        t = table(eps)
        mu_req = load_n / (w * scale * t["force"])
        if effective_temp_c is not None:
            temp = np.full_like(eps, effective_temp_c)
        else:
            torque = (mu_req * w * R**3 * L / C * 2 * math.pi / np.sqrt(1 - eps**2)
                      + eps * C * load_n * np.sin(t["attitude_rad"]) / 2)
            flow = R * C * w / (2 * math.pi) * L * (t["flow"] - t["side_flow"] / 2)
            temp = supply_temp_c + 0.5 * torque * w / (rho * oil.heat_capacity_j_kg_k * flow)
        return t, mu_req, temp

    def g(eps):
        _, mu_req, temp = operating(eps)
        with np.errstate(all="ignore"):
            return np.log(oil.dynamic_viscosity_pa_s(temp)) - np.log(mu_req)

    lo, hi = TABLE_EPS_RANGE
    lo_v, hi_v = np.full((speeds.size, 1), lo), np.full((speeds.size, 1), hi)
    for bound, sign, what in ((hi_v, -1, "above"), (lo_v, 1, "below")):
        g_bound = g(bound)[:, 0]
        bad = np.flatnonzero(~np.isfinite(g_bound))
        if bad.size:
            raise ModelError(
                f"at {speeds[bad[0]] * 30 / math.pi:.6g} rpm the film's heat balance leaves the "
                "oil model's range (no finite viscosity at an eccentricity ratio of "
                f"{bound[0, 0]}): load, speed or clearance far outside the bearing's design -- "
                "check load, clearance, oil and the bearing's speed_range_rpm")
        bad = np.flatnonzero(sign * g_bound > 0)
        if bad.size:
            raise ModelError(
                f"at {speeds[bad[0]] * 30 / math.pi:.6g} rpm the bearing would run at an "
                f"eccentricity ratio {what} {bound[0, 0]} (the range of the film table): "
                + ("speed too low or load too high for a hydrodynamic film" if sign < 0 else
                   "lightly loaded journal at high speed") + " -- check load, clearance, oil "
                "and the bearing's speed_range_rpm")
    for _ in range(60):                              # g increases with eps: bisection
        mid = 0.5 * (lo_v + hi_v)
        up = g(mid) > 0
        hi_v, lo_v = np.where(up, mid, hi_v), np.where(up, lo_v, mid)
    eps = 0.5 * (lo_v + hi_v)
    t, _, temp = operating(eps)
    mu = oil.dynamic_viscosity_pa_s(temp)[:, 0]
    k_scale = (mu * speeds * scale / C)[:, None, None]          # K = k_scale k, D = k_scale c / w
    return CoefficientTable(speeds, eps[:, 0], t["attitude_rad"][:, 0], temp[:, 0], mu,
                            k_scale * t["stiffness"][:, 0],
                            k_scale / w[:, :, None] * t["damping"][:, 0])
