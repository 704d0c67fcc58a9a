"""The common plant interface: a linear machine model in named generalised coordinates.

Every paper's machine becomes one :class:`LinearPlant` (DESIGN.md section 2)::

    M q'' + (D(w_F) + G(Omega)) q' + C(Omega, w_F) q = sum_k Re{F_k(Omega) u_k e^{j theta}}
                                                       + sum_i P_a,i f_a,i

with

* ``D(w_F) = D_eta / w_F + D_v`` -- loss-factor (hysteretic) damping ``d = c tan(delta) / w_F``
  (Werner 2021 eq. 8) plus any genuinely viscous damping;
* ``G(Omega) = Omega G1`` -- gyroscopic matrix (Werner 2021 eq. 12);
* ``C(Omega, w_F) = C + (Omega / w_F) N_eta`` -- stiffness plus the circulatory (skew) terms of
  rotating internal damping ``d_i Omega`` with ``d_i = c tan(delta_i) / w_F`` (Werner 2019, Werner 2017);
* optional terms that depend on speed and damping frequency, added to C and D (sleeve-bearing
  oil films and the electromagnetic field damping of Werner 2019);
* synchronous excitations whose force phasor per unit amplitude is
  ``F(Omega, Omega') = (Omega^2 - j Omega') p2 + Omega p1 + p0`` (unbalance: ``p2``, the
  ``-j Omega'`` part being the tangential force of an accelerating rotor; bent rotor: ``p0``;
  magnetic eccentricity: ``p0 + Omega p1``), optionally times a speed-dependent factor ``k(Omega)``
  (Werner 2019's magnetic eccentricity: ``k = c_md(Omega) - j Omega d_m(Omega)``). The physical force
  is ``Re{F u e^{j theta}}`` with the shaft angle ``theta`` and the complex amplitude ``u`` (for
  example ``u_e = m e e^{j phi}``);
* actuators: a force vector ``P_a`` and the displacement row ``s`` of the motion their controller
  measures (the absolute vertical motion of the machine foot);
* output rows: the quantities the papers plot, each a derivative (0, 1, 2) of ``row . q``.

The damping frequency ``w_F`` is always an explicit argument (DESIGN.md section 2): forced
response uses ``w_F = max(|Omega|, damping_floor_rad_s)``, stability analyses the whirl frequency.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from ..errors import ModelError

DERIVATIVE_NAMES = {0: "displacement", 1: "velocity", 2: "acceleration"}


@dataclass(frozen=True, eq=False)
class Excitation:
    """A synchronous excitation per unit complex amplitude (see the module docstring)."""

    name: str
    unit: str
    p2: np.ndarray
    p1: np.ndarray | None = None
    p0: np.ndarray | None = None
    #: optional ``speed (any shape) -> complex factor k(Omega)`` multiplying the whole phasor
    speed_factor: Callable[[np.ndarray], np.ndarray] | None = None

    def phasor(self, speed, accel=0.0) -> np.ndarray:
        """Force phasor(s) ``F(Omega, Omega')``; ``speed`` may be an array -> shape (N, n)."""
        speed = np.asarray(speed, dtype=float)
        accel = np.asarray(accel, dtype=float)
        w = speed[..., None]
        out = (w**2 - 1j * accel[..., None]) * self.p2
        if self.p1 is not None:
            out = out + w * self.p1
        if self.p0 is not None:
            out = out + self.p0 + 0.0 * w
        if self.speed_factor is not None:
            out = out * self.speed_factor(speed)[..., None]
        return out


@dataclass(frozen=True, eq=False)
class Output:
    """An output quantity ``d^order/dt^order (row . q)`` in SI units."""

    name: str
    row: np.ndarray
    order: int
    unit: str


@dataclass(frozen=True, eq=False)
class Actuator:
    """A force input ``P_a f`` and the displacement row ``s`` its controller feeds back."""

    id: str
    force_vector: np.ndarray
    sensor_row: np.ndarray
    axis: str = "z"


@dataclass(frozen=True, eq=False)
class LinearPlant:
    """A linear machine model; see the module docstring for the equation it carries."""

    name: str
    coords: tuple[str, ...]
    mass: np.ndarray
    stiffness: np.ndarray
    loss_damping: np.ndarray
    viscous_damping: np.ndarray
    gyroscopic: np.ndarray
    circulatory: np.ndarray
    actuators: tuple[Actuator, ...]
    excitations: tuple[Excitation, ...]
    outputs: tuple[Output, ...]
    damping_floor_rad_s: float
    #: optional ``(speed, w_F) (same shape) -> (dC, dD)`` of shape ``speed.shape + (n, n)``: the
    #: parts of stiffness and damping that depend on speed and damping frequency (sleeve-bearing
    #: oil films, electromagnetic field damping)
    speed_terms: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None
    #: the validated configuration the plant was built from (stored in bags and reports)
    config: dict = field(default_factory=dict)
    #: points whose actuator force is reported, as (id, axis); points without an actuator
    #: (a passive element) report zero force. Default: the actuators.
    force_points: tuple[tuple[str, str], ...] = ()

    def __post_init__(self):
        n = len(self.coords)
        for name in ("mass", "stiffness", "loss_damping", "viscous_damping", "gyroscopic",
                     "circulatory"):
            mat = getattr(self, name)
            if mat.shape != (n, n):
                raise ModelError(f"{self.name}: {name} has shape {mat.shape}, expected ({n}, {n})")
            if not np.all(np.isfinite(mat)):
                raise ModelError(f"{self.name}: {name} has non-finite entries")
        if not np.allclose(self.mass, self.mass.T, rtol=0, atol=1e-9 * np.abs(self.mass).max()):
            raise ModelError(f"{self.name}: the mass matrix is not symmetric")
        eig = np.linalg.eigvalsh(self.mass)
        if eig.min() <= 1e-12 * eig.max():
            raise ModelError(
                f"{self.name}: the mass matrix is singular or not positive definite "
                f"(smallest eigenvalue {eig.min():.3g}) -- every coordinate needs a positive "
                "mass or inertia; check the masses and inertias in the config")
        if not self.force_points:
            object.__setattr__(self, "force_points", tuple((a.id, a.axis) for a in self.actuators))
        ids = [a.id for a in self.actuators]
        if len(set(ids)) != len(ids):
            raise ModelError(f"{self.name}: duplicate actuator ids {ids}")

    # -- sizes and lookups -------------------------------------------------------------------
    @property
    def n(self) -> int:
        return len(self.coords)

    def actuator(self, actuator_id: str) -> Actuator:
        for act in self.actuators:
            if act.id == actuator_id:
                return act
        raise ModelError(f"{self.name}: no actuator {actuator_id!r}; the plant has "
                         + (", ".join(a.id for a in self.actuators) or "no actuators"))

    def excitation(self, name: str) -> Excitation:
        for exc in self.excitations:
            if exc.name == name:
                return exc
        raise ModelError(f"{self.name}: no excitation {name!r}; known: "
                         + ", ".join(e.name for e in self.excitations))

    def output(self, name: str) -> Output:
        for out in self.outputs:
            if out.name == name:
                return out
        raise ModelError(f"{self.name}: no output {name!r}")

    # -- matrices ----------------------------------------------------------------------------
    def forced_damping_frequency(self, speed):
        """``w_F`` of forced (unbalance) response: ``max(|Omega|, floor)`` (DESIGN.md 2)."""
        return np.maximum(np.abs(np.asarray(speed, dtype=float)), self.damping_floor_rad_s)

    def damping(self, speed, w_F) -> np.ndarray:
        """``D(w_F) + Omega G1`` (+ speed terms); array inputs give shape (N, n, n)."""
        speed = np.asarray(speed, dtype=float)
        w_F = np.broadcast_to(np.asarray(w_F, dtype=float), speed.shape)
        _check_w_F(w_F)
        out = (self.loss_damping / w_F[..., None, None] + self.viscous_damping
               + speed[..., None, None] * self.gyroscopic)
        if self.speed_terms is not None:
            out = out + self.speed_terms(speed, w_F)[1]
        return out

    def stiffness_at(self, speed, w_F) -> np.ndarray:
        """``C + (Omega / w_F) N_eta`` (+ speed terms); array inputs give shape (N, n, n)."""
        speed = np.asarray(speed, dtype=float)
        w_F = np.broadcast_to(np.asarray(w_F, dtype=float), speed.shape)
        _check_w_F(w_F)
        out = self.stiffness + (speed / w_F)[..., None, None] * self.circulatory
        if self.speed_terms is not None:
            out = out + self.speed_terms(speed, w_F)[0]
        return out

    def output_rows(self, names: Sequence[str] | None = None) -> tuple[list[str], np.ndarray, np.ndarray]:
        """Names, stacked rows (m, n) and derivative orders (m,) of the chosen outputs."""
        outs = self.outputs if names is None else [self.output(n) for n in names]
        return ([o.name for o in outs], np.array([o.row for o in outs]).reshape(len(outs), self.n),
                np.array([o.order for o in outs], dtype=int))


def _check_w_F(w_F: np.ndarray) -> None:
    if np.any(~np.isfinite(w_F)) or np.any(w_F <= 0.0):
        raise ModelError("the damping frequency w_F must be finite and > 0 "
                         "(loss-factor damping c tan(delta) / w_F is undefined at w_F = 0)")
