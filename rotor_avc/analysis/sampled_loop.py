"""The sampled-data closed loop under the sampling contract of DESIGN.md section 3.

At sample ``k`` each controlled foot measures its signal from the plant state ``x_k`` -- for
acceleration including the feed-through of the forces ``u_{k-1}`` held over the last interval
and the excitation force at ``t_k`` (Werner 2021 eqs. 20-24, ``D_st != 0``) -- its discrete filter
(:mod:`rotor_avc.control.discretize`, the same one the :class:`DigitalController` block runs) and
``d`` extra delay samples give ``u_k = -G_d(z) z^-d signal_k``, and the plant, exactly
ZOH-discretised (:func:`rotor_avc.models.discretize.discretize_plant`), holds ``u_k`` over
``[t_k, t_k+1)``. With the state ``X = [x; u_prev; controller states; delay lines]``::

    X_{k+1} = A_cl X_k + Re{ B_e a e^{j theta_k} }

(``a``: the complex excitation amplitudes, ``theta_k = Omega k T``). Hence

* discrete closed-loop poles: ``eig(A_cl)`` (``z``), with ``s = ln(z) / T`` to set beside the
  continuous poles; stable <=> ``max |z| < 1``;
* unbalance response at the sample instants: ``X_hat = (e^{j Omega T} I - A_cl)^{-1} B_e``, output
  and force phasors in the :class:`~rotor_avc.closed_loop.frf.SpeedFrf` form of
  :func:`~rotor_avc.closed_loop.frf.unbalance_frf` (same names, so the two overlay);
* the stable range of a common gain factor on all controllers (bisection on ``max |z| = 1``);
* the loop with forces added at any actuators and any measured quantities as outputs
  (:meth:`SampledLoop.with_inputs`: the state-space form the harmonic controller's analyses and
  its internal model build on).

An integrating controller (pole at z = 1) on velocity or acceleration leaves an exact closed-loop
eigenvalue at z = 1: the integrator can hold any constant force, against which the plant rests
in a static deflection that the derivative signal does not see (a drift mode; the continuous
:class:`ClosedLoop` cancels it). These "drift" eigenvalues are
reported apart and do not count for stability. Force and rate limits are not modelled (the
model holds while no limit is active). The damping frequency ``w_F`` is an explicit argument,
the same one the continuous model is evaluated with.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..control.block import DigitalController, build_digital_controllers
from ..control.discretize import DiscreteTf
from ..control.spec import FEEDBACK_ORDER
from ..errors import ModelError
from ..models.discretize import DiscretePlant, discretize_plant
from ..models.plant import LinearPlant
from ..closed_loop.frf import SpeedFrf
from .poles import pole_table
from .transfer import quantity

DRIFT_TOL = 1e-8


def _df2t_realisation(tf: DiscreteTf):
    """``(A, B, C, D)`` of the filter with the state of :class:`IirFilter` (DF2 transposed)."""
    b, a = tf.b, tf.a
    n = tf.order
    A = np.zeros((n, n))
    if n:
        A[:, 0] = -a[1:]
        A[:-1, 1:] = np.eye(n - 1)
    B = b[1:] - a[1:] * b[0]
    C = np.zeros(n)
    if n:
        C[0] = 1.0
    return A, B, C, float(b[0])


@dataclass
class _Assembly:
    A: np.ndarray            # (Nt, Nt) closed-loop transition
    Be: np.ndarray           # (Nt, ne) complex excitation input
    force_x: np.ndarray      # (m, Nt) u_k = force_x X_k + force_e e (the held actuators)
    force_e: np.ndarray      # (m, ne)
    dp: DiscretePlant
    held_forces: np.ndarray  # (n, m) force vectors of the held actuators (states N .. N + m)
    excitations: np.ndarray  # (n, ne) excitation phasors at the speed


@dataclass(frozen=True)
class LoopWithInput:
    """``X+ = A X + B f``, ``e = C X``: the sampled loop with forces ``f`` added at some
    actuators and the measured quantities ``e``; the plant's synchronous excitations
    (amplitudes ``a``, complex) enter as ``X+ = ... + Re{Be a e^{j theta_k}}``,
    ``e = ... + Re{De a e^{j theta_k}}``."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    n_drift: int
    Be: np.ndarray
    De: np.ndarray


@dataclass
class SampledPoles:
    """Discrete closed-loop poles at one speed and damping frequency."""

    speed_rad_s: float
    w_F: float
    sample_period_s: float
    z: np.ndarray            # all eigenvalues except the drift ones
    drift: np.ndarray        # eigenvalues at z = 1 from integrators on derivative signals

    @property
    def s(self) -> np.ndarray:
        """Equivalent continuous poles ``ln(z) / T`` (z = 0 maps to -inf)."""
        z = self.z.astype(complex)
        s = np.full(z.shape, complex(-np.inf, 0.0))
        nonzero = z != 0
        s[nonzero] = np.log(z[nonzero]) / self.sample_period_s
        return s

    @property
    def max_abs_z(self) -> float:
        return float(np.max(np.abs(self.z))) if self.z.size else 0.0

    @property
    def stable(self) -> bool:
        return self.max_abs_z < 1.0

    def table(self) -> list[dict]:
        """:func:`pole_table` rows of the finite equivalent s-poles."""
        s = self.s
        return pole_table(s[np.isfinite(s)])


@dataclass
class GainRange:
    """Stable range ``lower < g < upper`` of a common factor ``g`` on all controllers' gains."""

    sample_rate_hz: float
    speed_rad_s: float
    w_F: float
    lower: float             # 0 when stable down to zero gain
    upper: float             # inf when stable up to the largest factor searched
    stable_at_nominal: bool
    max_abs_z_nominal: float
    searched_up_to: float
    searched_from: float = 1e-4

    @property
    def found(self) -> bool:
        """Whether any factor searched gives a stable loop (else ``lower``/``upper`` are NaN)."""
        return not np.isnan(self.lower)

    def describe(self, nominal: dict[str, str] | None = None) -> str:
        state = (f"(nominal g = 1 {'stable' if self.stable_at_nominal else 'UNSTABLE'}, "
                 f"max |z| = {self.max_abs_z_nominal:.6f})")
        if not self.found:
            return (f"{self.sample_rate_hz:g} Hz: no stable gain factor g in "
                    f"[{self.searched_from:g}, {self.searched_up_to:g}] {state} -- the design "
                    "itself (structure, sign, G_c poles or rate) must change")
        up = (f">= {self.searched_up_to:g} (stable over the whole search)" if np.isinf(self.upper)
              else f"{self.upper:.4g}")
        txt = f"{self.sample_rate_hz:g} Hz: stable gain factor {self.lower:.4g} < g < {up} {state}"
        return txt + ("".join(f"\n  {k}: {v}" for k, v in nominal.items()) if nominal else "")


@dataclass(frozen=True, eq=False)
class SampledLoop:
    """A plant with discrete controllers (one per controlled actuator) and their delays."""

    plant: LinearPlant
    controllers: dict[str, DiscreteTf]
    delay_samples: dict[str, int]
    #: the sample period when no controller gives it (all loops open: the exact sampled plant)
    period_s: float | None = None

    def __post_init__(self):
        periods = {tf.sample_period_s for tf in self.controllers.values()}
        if self.period_s is not None:
            periods.add(self.period_s)
        if len(periods) != 1:
            raise ModelError("all controllers must share one sample period, and a loop without "
                             f"controllers needs one given (got {sorted(periods)})")
        for act_id in self.controllers:
            self.plant.actuator(act_id)

    @classmethod
    def from_blocks(cls, plant: LinearPlant, blocks: dict[str, DigitalController],
                    sample_period_s: float | None = None) -> "SampledLoop":
        """The loop the blocks run (their current gain factor and delays included)."""
        return cls(plant, {k: b.tf.scaled(b.gain) for k, b in blocks.items()},
                   {k: b.delay_samples for k, b in blocks.items()},
                   None if blocks else sample_period_s)

    @property
    def sample_period_s(self) -> float:
        if self.period_s is not None:
            return self.period_s
        return next(iter(self.controllers.values())).sample_period_s

    # -- assembly ----------------------------------------------------------------------------
    def _measurement(self, row, order, dp, Pc, F, Nt):
        """``signal = mX @ X + me @ e`` for a displacement row of the given derivative order."""
        n, N = self.plant.n, 2 * self.plant.n
        mX = np.zeros(Nt)
        me = np.zeros(F.shape[1], complex)
        if order == 0:
            mX[:n] = row
        elif order == 1:
            mX[n:N] = row
        else:
            rm = row @ dp.accel_force
            mX[:N] = row @ dp.accel_state
            mX[N:N + Pc.shape[1]] = rm @ Pc
            me = rm @ F
        return mX, me

    def assemble(self, speed_rad_s: float, w_F: float, gain: float = 1.0,
                 dp: DiscretePlant | None = None, held: list[str] | None = None) -> _Assembly:
        """Closed-loop ``A_cl``, ``B_e`` and the force rows (module docstring); ``held``: the
        actuators whose held forces are states (default: the controlled ones)."""
        p = self.plant
        T = self.sample_period_s
        if dp is None:
            dp = discretize_plant(p, speed_rad_s, w_F, T)
        n, N = p.n, 2 * p.n
        ids = list(self.controllers) if held is None else list(held)
        m = len(ids)
        acts = [p.actuator(i) for i in ids]
        Pc = np.array([a.force_vector for a in acts]).reshape(m, n).T    # (n, m)
        cols = [p.actuators.index(a) for a in acts]
        Gu = dp.Gamma_u[:, cols]
        F = np.array([e.phasor(speed_rad_s) for e in p.excitations]).reshape(-1, n).T  # (n, ne)
        ne = F.shape[1]
        reals = [_df2t_realisation(tf.scaled(gain)) for tf in self.controllers.values()]
        delays = [self.delay_samples.get(c, 0) for c in self.controllers]
        Nt = N + m + sum(r[0].shape[0] for r in reals) + sum(delays)
        A = np.zeros((Nt, Nt))
        Be = np.zeros((Nt, ne), complex)
        uX = np.zeros((m, Nt))
        ue = np.zeros((m, ne), complex)
        k = N + m
        for c, tf, (Ac, Bc, Cc, Dc), d in zip(self.controllers, self.controllers.values(),
                                              reals, delays):
            i = ids.index(c)
            mX, me = self._measurement(p.actuator(c).sensor_row, FEEDBACK_ORDER[tf.feedback], dp,
                                       Pc, F, Nt)
            nc = Ac.shape[0]
            xi = slice(k, k + nc)
            if d:
                w0 = k + nc
                A[w0] = mX
                Be[w0] = me
                for j in range(1, d):
                    A[w0 + j, w0 + j - 1] = 1.0
                tX = np.zeros(Nt)
                tX[w0 + d - 1] = 1.0
                te = np.zeros(ne, complex)
            else:
                tX, te = mX, me
            A[xi, xi] = Ac
            A[xi] += np.outer(Bc, tX)
            Be[xi] = np.outer(Bc, te)
            uX[i, xi] = -Cc
            uX[i] -= Dc * tX
            ue[i] = -Dc * te
            k += nc + d
        A[:N, :N] = dp.Phi
        A[:N] += Gu @ uX
        Be[:N] = dp.Gamma_e + Gu @ ue
        A[N:N + m] = uX
        Be[N:N + m] = ue
        return _Assembly(A, Be, uX, ue, dp, Pc, F)

    def with_inputs(self, speed_rad_s: float, w_F: float, input_ids, output_names
                    ) -> LoopWithInput:
        """The loop with forces added at ``input_ids`` and the measured quantities
        ``output_names`` (plant outputs, ``foot_<id>_{d,v,a}<axis>``) as outputs; every
        actuator's held force is a state."""
        p = self.plant
        asm = self.assemble(speed_rad_s, w_F, held=[a.id for a in p.actuators])
        ids = [a.id for a in p.actuators]
        N, na, Nt = 2 * p.n, len(ids), asm.A.shape[0]
        S = np.zeros((na, len(input_ids)))
        for j, a in enumerate(input_ids):
            S[ids.index(p.actuator(a).id), j] = 1.0
        B = np.zeros((Nt, len(input_ids)))
        B[:N] = asm.dp.Gamma_u @ S
        B[N:N + na] = S
        rows = []
        for name in output_names:
            kind, row, order, _ = quantity(p, name)
            if kind != "row":
                raise ModelError(f"{name!r} is a force, not a measured quantity")
            rows.append(self._measurement(row, order, asm.dp, asm.held_forces, asm.excitations,
                                          Nt))
        C = np.array([r for r, _ in rows]).reshape(-1, Nt)
        De = np.array([t for _, t in rows]).reshape(len(rows), asm.excitations.shape[1])
        return LoopWithInput(asm.A, B, C, self._n_drift(), asm.Be, De)

    def _n_drift(self) -> int:
        """Held-force modes: one per controller with a pole at z = 1 on velocity or acceleration
        (a constant output is an exact equilibrium; the ramp mode of a double integrator is not,
        as the staircase ramp force leaves a nonzero sampled derivative signal)."""
        return sum(1 for tf in self.controllers.values() if tf.feedback != "displacement"
                   and abs(tf.a.sum()) <= 1e-10 * np.abs(tf.a).sum())

    # -- analyses ----------------------------------------------------------------------------
    def poles(self, speed_rad_s: float, w_F: float, gain: float = 1.0,
              dp: DiscretePlant | None = None) -> SampledPoles:
        """Discrete closed-loop poles; drift eigenvalues (z = 1) split off (module docstring)."""
        A = self.assemble(speed_rad_s, w_F, gain, dp).A
        z = scipy.linalg.eigvals(A)
        n_drift = self._n_drift()
        drift_idx = np.argsort(np.abs(z - 1.0))[:n_drift]
        drift_idx = drift_idx[np.abs(z[drift_idx] - 1.0) <= DRIFT_TOL]
        keep = np.ones(z.size, bool)
        keep[drift_idx] = False
        return SampledPoles(float(speed_rad_s), float(w_F), self.sample_period_s, z[keep],
                            z[drift_idx])

    def unbalance_frf(self, speed_rad_s, excitations=None, w_F=None) -> SpeedFrf:
        """Synchronous response at the sample instants, in :func:`unbalance_frf`'s form."""
        p = self.plant
        T = self.sample_period_s
        speeds = np.atleast_1d(np.asarray(speed_rad_s, dtype=float))
        if speeds.ndim != 1 or speeds.size == 0 or np.any(~np.isfinite(speeds)) or np.any(speeds <= 0):
            raise ModelError("FRF speeds must be a non-empty list of positive, finite speeds")
        if speeds.max() >= np.pi / T:
            raise ModelError(f"rotor speed {speeds.max() / (2 * np.pi):g} Hz is at or above the "
                             f"Nyquist frequency {0.5 / T:g} Hz of the {1 / T:g} Hz controller: the "
                             "synchronous response aliases -- raise the sample rate")
        names = [e.name for e in p.excitations]
        chosen = names if excitations is None else [p.excitation(e).name for e in excitations]
        cols = [names.index(e) for e in chosen]
        w_F = p.forced_damping_frequency(speeds) if w_F is None else np.broadcast_to(w_F, speeds.shape)
        out_names, rows, orders = p.output_rows()
        ids = list(self.controllers)
        n_out, n_f = len(out_names), len(p.force_points)
        resp = np.zeros((speeds.size, n_out + n_f, len(cols)), complex)
        for k, (speed, wf) in enumerate(zip(speeds, w_F)):
            asm = self.assemble(speed, wf)
            Nt = asm.A.shape[0]
            zk = np.exp(1j * speed * T)
            X = np.linalg.solve(zk * np.eye(Nt) - asm.A, asm.Be[:, cols])
            F = np.array([p.excitations[c].phasor(speed) for c in cols]).reshape(-1, p.n).T
            Pc = np.array([p.actuator(i).force_vector for i in ids]).reshape(len(ids), p.n).T
            for j, (row, order) in enumerate(zip(rows, orders)):
                yX, ye = self._measurement(row, order, asm.dp, Pc, F, Nt)
                resp[k, j] = yX @ X + ye
            for j, (act_id, _) in enumerate(p.force_points):
                if act_id in self.controllers:
                    i = ids.index(act_id)
                    resp[k, n_out + j] = asm.force_x[i] @ X + asm.force_e[i, cols]
        result = SpeedFrf(speeds, {}, {}, {})
        excs = [p.excitations[c] for c in cols]
        for j, out in enumerate(p.outputs):
            for c, e in enumerate(excs):
                result.add(out.name, e.name, resp[:, j, c], f"{out.unit}/({e.unit})")
        for j, (act_id, axis) in enumerate(p.force_points):
            for c, e in enumerate(excs):
                result.add(f"actuator_{act_id}_f{axis}", e.name, resp[:, n_out + j, c],
                           f"N/({e.unit})")
        return result

    def stable_gain_range(self, speed_rad_s: float, w_F: float, max_factor: float = 1e4,
                          min_factor: float = 1e-4, points_per_decade: int = 6,
                          rtol: float = 1e-3) -> GainRange:
        """Stable interval of a common gain factor ``g`` (containing g = 1 when stable there,
        else the first stable interval above ``min_factor``): log-grid scan then bisection of
        ``max |z| = 1`` at both ends."""
        if not (0 < min_factor < 1 < max_factor) or points_per_decade < 1 or not 0 < rtol < 1:
            raise ModelError("gain search needs 0 < min_factor < 1 < max_factor, "
                             "points_per_decade >= 1 and 0 < rtol < 1")
        dp = discretize_plant(self.plant, speed_rad_s, w_F, self.sample_period_s)
        margin = lambda g: self.poles(speed_rad_s, w_F, g, dp).max_abs_z  # noqa: E731
        n_dec = np.log10(max_factor / min_factor)
        grid = np.unique(np.concatenate([
            np.logspace(np.log10(min_factor), np.log10(max_factor),
                        int(np.ceil(n_dec * points_per_decade)) + 1), [1.0]]))
        stable = np.array([margin(g) < 1.0 for g in grid])
        nominal = margin(1.0)
        i_nom = int(np.flatnonzero(grid == 1.0)[0])
        start = i_nom if stable[i_nom] else (int(np.argmax(stable)) if stable.any() else None)
        if start is None:
            return GainRange(1 / self.sample_period_s, speed_rad_s, w_F, np.nan, np.nan, False,
                             nominal, max_factor, min_factor)

        def edge(g_in, g_out):
            while g_out / g_in - 1.0 > rtol:
                g_mid = np.sqrt(g_in * g_out)
                g_in, g_out = (g_mid, g_out) if margin(g_mid) < 1.0 else (g_in, g_mid)
            return np.sqrt(g_in * g_out)

        hi = start
        while hi + 1 < grid.size and stable[hi + 1]:
            hi += 1
        lo = start
        while lo > 0 and stable[lo - 1]:
            lo -= 1
        upper = np.inf if hi == grid.size - 1 else edge(grid[hi], grid[hi + 1])
        if lo > 0:
            lower = edge(grid[lo], grid[lo - 1])
        else:                      # stable down to min_factor: 0 if the open loop is stable too
            lower = 0.0 if margin(0.0) < 1.0 else min_factor
        return GainRange(1 / self.sample_period_s, float(speed_rad_s), float(w_F), float(lower),
                         float(upper), bool(nominal < 1.0), nominal, max_factor, min_factor)


def machine_sampled_loop(machine, sample_period_s: float | None = None) -> SampledLoop:
    """The sampled loop of a configured machine (its ``control:`` settings unless ``T`` given);
    with its loops open, the exact sampled plant at ``T`` (default: the control rate)."""
    blocks = build_digital_controllers(machine, sample_period_s)
    if not blocks and sample_period_s is None:
        sample_period_s = 1.0 / machine.sample_rate_hz
    return SampledLoop.from_blocks(machine.plant, blocks, sample_period_s)


def gain_ranges(machine, sample_rates_hz, speed_rad_s: float, w_F: float, **search) -> list[GainRange]:
    """:meth:`SampledLoop.stable_gain_range` of a machine at each sample rate."""
    return [machine_sampled_loop(machine, 1.0 / float(f)).stable_gain_range(speed_rad_s, w_F, **search)
            for f in sample_rates_hz]
