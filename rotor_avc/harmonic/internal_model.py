"""The dynamic feed-forward of harmonic control: an internal model of the loop, run on the
excitation estimate.

Quasi-steady phasors ``U = -pinv(G) H C`` (:mod:`.block`) cancel the 1x response only as long as
the speed changes slowly against the settling of the lightly damped modes and of the zeros of
``G`` (near a rank loss of ``G`` the phasors turn fast with speed, and the loop lags them). The
dynamic feed-forward instead runs the sampled-loop model (:meth:`rotor_avc.analysis.sampled_loop.SampledLoop.with_inputs`: plant,
feedback controllers, the block's actuators and sensors) on the estimated excitations ``C``::

    x_{k+1} = A x_k + B u_k + Re{Be C e^{j theta_k}},      y_k = Cy x_k + Re{De C e^{j theta_k}}
    u_k = Re{U e^{j theta_k}} - K x_k

with ``K`` the discrete LQ gain of ``(A, B)`` on the sensors (``Q = Cy' W Cy``, ``R = rho
s_max(Cy B)^2 I``): the model's modes damped by a state feedback that needs no measurement, since
for an exact model and estimate ``x`` is the plant's own state. ``U`` makes the internal loop's
steady 1x response at the sensors zero (``U = -pinv(Cy Mu) Cy Me C``, ``Mu, Me = (e^{j Omega T}
I - A_c)^{-1} (B, Be)``, ``A_c = A - B K``), so the forces are the internal loop's response to
the estimated unbalance: exact during a run-up where the quasi-steady phasors lag. With the
model's predicted sensor signal ``y_k`` subtracted, the measured signals leave the response of
the loop to the estimate's error alone, ``E = H (C_true - C)`` (:attr:`HarmonicSchedule.
disturbance`), which the block's law adapts ``C`` on.

Per block of ``r`` samples (the block's ``refresh_samples``) the speed is frozen at the nearest
table node and the state is split into the steady part ``Re{X_ss e^{j theta}}`` (``X_ss = Mu U +
Me C``) and the transient ``x~``, which follows ``A_c``: the block's forces and predicted signals
are ``Re{(U - K X_ss) e^{j theta_k}} - K A_c^i x~`` and ``Re{(Cy X_ss + De C) e^{j theta_k}} + Cy
A_c^i x~`` (tables of ``K A_c^i``, ``Cy A_c^i`` and ``A_c^r`` per node), and at the block's end
``x~ <- A_c^r x~ + Re{(X_ss,old - X_ss,new) e^{j theta}}`` keeps the state continuous through
the change of speed and estimate (a new estimate starts a block at once, after ``A_c^i``). Numpy runs once per block; per sample the block adds one
stored force and signal value per channel.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..closed_loop.speed_table import interpolate
from ..errors import ModelError

#: the LQ force weight relative to the largest one-step sensor response per unit force
DEFAULT_EFFORT = 1e-2
#: weight of the feedback controllers' states (relative to a sensor's), with the Riccati
#: equation solved for ``A / DISCOUNT``: solvable with a mode on the unit circle that the
#: sensors do not see and the forces do not move (a feedback integrator's drift, which stays)
CONTROLLER_WEIGHT = 1e-6
DISCOUNT = 1.0 + 1e-6


@dataclass(frozen=True, eq=False)
class InternalTables:
    """Per node ``s`` of ``speeds_rad_s``: the internal loop's transition ``Ac[s]``, the block
    transition ``Ar[s] = A_c^r`` and the transient rows ``W[s, i] = [-K A_c^i; Cy A_c^i]`` (N forces, M sensors) for ``i < r``, used
    at the nearest node; and, per unit estimate ``C`` and interpolated in speed, the phasors
    ``Uc`` (``U = -Uc C``), the steady state ``Xc``, force phasor ``Fc`` (``U - K X_ss``) and
    sensor phasor ``Yc`` (zero where ``Cy Mu`` has full row rank)."""

    speeds_rad_s: np.ndarray
    sample_period_s: float
    refresh: int
    Ac: np.ndarray
    Ar: np.ndarray
    W: np.ndarray
    Uc: np.ndarray
    Xc: np.ndarray
    Fc: np.ndarray
    Yc: np.ndarray

    def node(self, speed_rad_s: float) -> int:
        """The nearest node (in log speed)."""
        sp = self.speeds_rad_s
        k = int(np.searchsorted(sp, speed_rad_s))
        if k <= 0:
            return 0
        if k >= sp.size:
            return sp.size - 1
        return k if sp[k] * sp[k - 1] < speed_rad_s ** 2 else k - 1

    def steady(self, name: str, speed_rad_s: float) -> np.ndarray:
        """One of the steady maps ``Uc``, ``Xc``, ``Fc``, ``Yc`` at this speed."""
        return interpolate(self.speeds_rad_s, getattr(self, name), speed_rad_s)

    def steady_times(self, C: np.ndarray, speed_rad_s: float) -> list[np.ndarray]:
        """``[Uc C, Xc C, Fc C, Yc C]`` at this speed (:meth:`steady`; one table lookup and one
        product on the stacked maps)."""
        v = interpolate(self.speeds_rad_s, self._stacked, speed_rad_s) @ C
        return [v[s] for s in self._slices]

    def __post_init__(self):
        maps = (self.Uc, self.Xc, self.Fc, self.Yc)
        ends = np.cumsum([m.shape[1] for m in maps])
        object.__setattr__(self, "_stacked", np.concatenate(maps, axis=1))
        object.__setattr__(self, "_slices", [slice(a, b) for a, b in zip([0, *ends[:-1]], ends)])
        object.__setattr__(self, "_block_times_s",
                           self.sample_period_s * np.arange(self.refresh))


def internal_tables(loop, actuators, sensors, speeds_rad_s, refresh: int, w_F=None,
                    effort: float = DEFAULT_EFFORT, sensor_weights=None) -> InternalTables:
    """The tables of the internal loop (module docstring) at each speed; ``w_F``: ``None`` for
    the plant's damping rule at each speed, or a frozen damping frequency (rad/s)."""
    if not (refresh >= 1 and effort > 0):
        raise ModelError("the dynamic feed-forward needs refresh_samples >= 1 and an effort "
                         "weight > 0")
    T = loop.sample_period_s
    speeds = np.asarray(speeds_rad_s, dtype=float)
    weights = np.ones(len(sensors)) if sensor_weights is None else np.asarray(sensor_weights)
    out = {k: [] for k in ("Ac", "Ar", "W", "Uc", "Xc", "Fc", "Yc")}
    for speed in speeds:
        wf = float(loop.plant.forced_damping_frequency(speed)) if w_F is None else w_F
        lwi = loop.with_inputs(speed, wf, actuators, sensors)
        A, B, Cy = lwi.A, lwi.B, lwi.C
        Nt = A.shape[0]
        Q = Cy.T @ (weights[:, None] * Cy)
        ctrl = slice(2 * loop.plant.n + len(loop.plant.actuators), Nt)
        Q[ctrl, ctrl] += CONTROLLER_WEIGHT * np.trace(Q) / len(sensors) * np.eye(Nt - ctrl.start)
        R = effort * np.linalg.norm(Cy @ B, 2) ** 2 * np.eye(B.shape[1])
        try:
            P = scipy.linalg.solve_discrete_are(A / DISCOUNT, B / DISCOUNT, Q, R)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise ModelError(f"no LQ state feedback for the internal model at "
                             f"{speed / (2 * np.pi):.4g} Hz ({exc}); use feedforward: "
                             "quasi_static") from None
        K = np.linalg.solve(R * DISCOUNT ** 2 + B.T @ P @ B, B.T @ P @ A)
        Ac = A - B @ K
        rows = np.vstack([-K, Cy])
        W = np.empty((refresh, rows.shape[0], Nt))
        for i in range(refresh):
            W[i] = rows
            rows = rows @ Ac
        Xu, Xe = np.split(np.linalg.solve(np.exp(1j * speed * T) * np.eye(Nt) - Ac,
                                          np.hstack([B, lwi.Be])), [B.shape[1]], axis=1)
        Uc = np.linalg.pinv(Cy @ Xu) @ (Cy @ Xe + lwi.De)
        Xc = Xe - Xu @ Uc
        out["Ac"].append(Ac)
        out["Ar"].append(np.linalg.matrix_power(Ac, refresh))
        out["W"].append(W)
        out["Uc"].append(Uc)
        out["Xc"].append(Xc)
        out["Fc"].append(-Uc - K @ Xc)
        out["Yc"].append(Cy @ Xc + lwi.De)
    return InternalTables(speeds, T, refresh, **{k: np.array(v) for k, v in out.items()})


class InternalLoop:
    """The internal loop's state over blocks (module docstring): :meth:`advance` at each block's
    first sample gives the block's phasors and transient sequences."""

    def __init__(self, tables: InternalTables):
        self.tables = tables
        self.reset()

    def reset(self) -> None:
        """At rest: no transient, no steady state (a zero estimate)."""
        Nt = self.tables.Ar.shape[1]
        self.x = np.zeros(Nt)
        self.X_ss = np.zeros(Nt, complex)
        self.node = None

    @property
    def state(self) -> dict:
        return {"x": self.x.copy(), "X_ss": self.X_ss.copy(), "node": self.node}

    def set_state(self, state: dict) -> None:
        x, X_ss = np.asarray(state["x"], float), np.asarray(state["X_ss"], complex)
        if x.shape != self.x.shape or X_ss.shape != self.X_ss.shape:
            raise ModelError("internal-model state does not fit the tables")
        self.x, self.X_ss, self.node = x.copy(), X_ss.copy(), state["node"]

    def advance(self, C: np.ndarray, angle: float, speed_rad_s: float, elapsed: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """End the running block after its ``elapsed`` samples (``r``, or fewer when a new
        estimate starts a block early), start one at this sample with the estimate ``C``:
        ``(U, force phasors (N,), transient forces (r, N), predicted signals (r, M))``."""
        t = self.tables
        if self.node is not None:
            if elapsed == t.refresh:
                self.x = t.Ar[self.node] @ self.x
            else:
                for _ in range(elapsed):
                    self.x = t.Ac[self.node] @ self.x
        UC, X_ss, F, Y = t.steady_times(C, speed_rad_s)
        self.x += ((self.X_ss - X_ss) * np.exp(1j * angle)).real
        self.X_ss = X_ss
        self.node = t.node(speed_rad_s)
        seq = t.W[self.node] @ self.x                                   # (r, N + M)
        n = UC.size
        steps = np.exp(1j * (angle + speed_rad_s * t._block_times_s))
        y = seq[:, n:] + (Y[None, :] * steps[:, None]).real
        return -UC, F, seq[:, :n], y

    def scale(self, factor: float) -> None:
        """The whole internal trajectory times ``factor`` (as if the estimate had always been
        ``factor`` times): the block's force limits."""
        self.x *= factor
        self.X_ss *= factor
