"""The plant block: a LinearPlant stepped exactly at a fixed sample period (DESIGN.md section 3).

Sampling contract, sample ``k`` at ``t_k = k T``:

1. the measurement ``y_k`` (returned by :meth:`~PlantStepper.reset` for ``k = 0`` and by
   :meth:`~PlantStepper.step` after that) comes from the state ``x_k = [q; q']``, the forces
   ``u_{k-1}`` held over the last interval and the excitation at ``t_k``: per actuator the foot
   displacement, velocity and acceleration of its sensor row (the acceleration includes the
   force feed-through ``M^-1 (P_a u_{k-1} + f_e(t_k))``), then every ``plant.outputs`` quantity;
2. the controllers compute ``u_k`` from ``y_k``;
3. :meth:`~PlantStepper.step` holds ``u_k`` over ``[t_k, t_k+1)`` and advances to ``x_{k+1}``.

Unbalance forcing (Werner 2021 eqs. 13-14 in real form with ``theta = int Omega dt``, and
the tangential ``-j Omega'`` term of an accelerating rotor, Zhou & Shi 2001 eq. 1)::

    f_e(t) = Re{ sum_j k_j(Omega) [(Omega^2 - j Omega') p2_j + Omega p1_j + p0_j] (u_j + c_j)
                 e^{j theta} }

(``Excitation.phasor``, with its optional speed factor ``k_j``) with the amplitudes ``u_j`` of
the run and the balancer's corrections ``c_j`` (:meth:`~PlantStepper.set_correction`, effective
from the next step on).

A broadband test force ``d_k`` (:class:`rotor_avc.sim.broadband.BroadbandForce`, optional) is
added to the forces of its actuator: the plant holds ``u_k + d_k`` over ``[t_k, t_k+1)``, and the
acceleration at ``t_k+1`` carries its feed-through like that of ``u_k``.

One sample is one mat-vec at constant speed (:mod:`rotor_avc.sim.propagator` folds
propagation, measurement and the rotating excitation into one matrix); while the speed changes,
two more (interpolation) and one small one (measurement speed).

Accuracy (stated and tested in ``test/test_sim_stepper.py``):

* constant speed: the exact ZOH solution, to rounding (1e-9 against the continuous FRF and
  ``discretize_plant``, any sample rate);
* changing speed: the interval ``[t_k, t_k+1)`` uses the propagator at the midpoint speed
  ``Omega(t_k + T/2)`` (exponential midpoint rule, second order in ``T``), the shaft angle is
  restarted at its exact value ``theta(t_k)`` every sample, and the propagators are interpolated
  between speed nodes that keep the speed-dependent matrices within ``grid_tol`` (relative) of
  the exact ones and an undamped rotor's energy within ``grid_tol`` per simulated second. A
  run-up through a resonance (Werner 2021 case 1, 30 -> 46 Hz in 1 s, 5 kHz) stays within 1e-5 of
  ``solve_ivp`` (DOP853, rtol 1e-11) relative to the peak -- measured 2e-6. Fast ramps at low
  speed with stepped forces are the hard case (case 2, 10 -> 60 Hz in 0.2 s, random held forces:
  8e-4 in the foundation velocities of the overdamped local modes; halve ``T`` for a quarter).
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from ..errors import ModelError
from ..models.plant import LinearPlant
from ..settings import DEFAULT_GRID_TOL
from .broadband import BroadbandForce
from .propagator import (DampingRule, PropagatorTable, basis_coefficients, max_node_spacing,
                         speed_nodes)
from .speed_profile import SpeedProfile

#: samples whose speed, angle and node lookups are precomputed at once
CHUNK = 4096
MEASURE_KINDS = (("d", 0), ("v", 1), ("a", 2))


class MeasurementLayout:
    """Names, units, rows and derivative orders of the measurement vector ``y``."""

    def __init__(self, plant: LinearPlant):
        names, units, rows, orders = [], [], [], []
        unit = {0: "m", 1: "m/s", 2: "m/s^2"}
        for act in plant.actuators:
            for letter, order in MEASURE_KINDS:
                names.append(f"foot_{act.id}_{letter}{act.axis}")
                units.append(unit[order])
                rows.append(act.sensor_row)
                orders.append(order)
        for out in plant.outputs:
            names.append(out.name)
            units.append(out.unit)
            rows.append(out.row)
            orders.append(out.order)
        self.names = names
        self.units = dict(zip(names, units))
        self.rows = np.array(rows, dtype=float).reshape(len(names), plant.n)
        self.orders = np.array(orders, dtype=int)
        self._index = {name: i for i, name in enumerate(names)}
        self._axis = {a.id: a.axis for a in plant.actuators}

    def index(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise ModelError(f"no measured quantity {name!r}") from None

    def feedback_index(self, actuator_id: str, feedback: str) -> int:
        """Index of the signal a controller with ``feedback`` kind reads at ``actuator_id``."""
        letter = {"displacement": "d", "velocity": "v", "acceleration": "a"}[feedback]
        return self.index(f"foot_{actuator_id}_{letter}{self._axis[actuator_id]}")


class PlantStepper:
    """Exact sampled-data plant with a speed profile (see the module docstring)."""

    def __init__(self, plant: LinearPlant, sample_period_s: float, profile: SpeedProfile,
                 amplitudes: Mapping[str, complex] | None = None,
                 damping: DampingRule = DampingRule(), grid_tol: float = DEFAULT_GRID_TOL,
                 test_force: BroadbandForce | None = None, table: PropagatorTable | None = None):
        T = float(sample_period_s)
        if not (np.isfinite(T) and T > 0):
            raise ModelError(f"sample period must be > 0 (got {sample_period_s})")
        self.plant = plant
        self.T = T
        self.profile = profile
        self.damping = damping
        self.layout = MeasurementLayout(plant)
        grid = (T, damping, profile.min_speed_rad_s, profile.max_speed_rad_s,
                tuple(profile.held_speeds()), grid_tol)
        if table is not None and (table.plant is not plant or table.grid != grid):
            raise ModelError("a propagator table is reused only by a stepper of the same plant, "
                             "sample period, damping rule, speed range, held speeds and grid_tol")
        if table is None:
            nodes = speed_nodes(plant, damping, profile.min_speed_rad_s, profile.max_speed_rad_s,
                                profile.held_speeds(), grid_tol,
                                max_node_spacing(plant, T, grid_tol))
            table = PropagatorTable(plant, T, damping, nodes, self.layout.rows,
                                    self.layout.orders)
            table.grid = grid
        #: the speed grid and its matrices (pass it to the next stepper of the same run setup)
        self.table = table
        lay = self.table.layout
        self._lay = lay
        self._N = 2 * plant.n
        self.n_inputs = lay.u.stop - lay.u.start
        self._exc_of_basis = np.array([b.excitation for b in self.table.bases], dtype=int)
        self.test_force = test_force
        self._test_at = self._d = None
        if test_force is not None:
            plant.actuator(test_force.actuator)         # raises, naming the plant's actuators
            if abs(test_force.sample_period_s - T) > 1e-12 * T:
                raise ModelError(f"the test force is sampled at {1 / test_force.sample_period_s:g}"
                                 f" Hz, the plant at {1 / T:g} Hz; they must share one rate")
            self._test_at = lay.u.start + [a.id for a in plant.actuators].index(test_force.actuator)
        self._base_amp = np.zeros(len(plant.excitations), complex)
        self._corr = np.zeros(len(plant.excitations), complex)
        self.set_amplitudes(amplitudes or {})
        self._v = np.zeros(lay.size)                  # [x_k | u_k | w_mid,k | w_meas,k+1]
        self._u_slice = lay.u
        self._w_slice = slice(lay.w.start, lay.size)
        self._w_both = self._v[self._w_slice].view(np.complex128)
        self._W = None
        self._y = np.zeros(len(self.layout.names))
        self.k = 0
        self._k0 = 0
        self._n_chunk = 0

    # -- amplitudes ---------------------------------------------------------------------------
    def _excitation_index(self, name: str) -> int:
        names = [e.name for e in self.plant.excitations]
        if name not in names:
            self.plant.excitation(name)          # raises, naming the known excitations
        return names.index(name)

    def _update_amp(self) -> None:
        amp = (self._base_amp + self._corr)[self._exc_of_basis]
        self._amp2 = np.concatenate([amp, amp])

    def basis_amplitudes(self, speed, accel) -> np.ndarray:
        """Complex coefficient ``w_b / e^{j theta}`` of every force basis vector at ``speed``,
        ``accel`` with the current amplitudes (see :mod:`rotor_avc.sim.propagator`)."""
        return self.coefficients(speed, accel) * self._amp2[:len(self._exc_of_basis)]

    def set_amplitudes(self, amplitudes: Mapping[str, complex]) -> None:
        """Complex amplitude per excitation name (e.g. ``{"static": m e e^{j phi}}``)."""
        base = np.zeros(len(self.plant.excitations), complex)
        for name, value in amplitudes.items():
            value = complex(value)
            if not np.isfinite(value):
                raise ModelError(f"unbalance amplitude {name!r} must be finite (got {value})")
            base[self._excitation_index(name)] = value
        self._base_amp = base
        self._update_amp()
        self._W = None

    def set_correction(self, corrections: Mapping[str, complex]) -> None:
        """The balancer's correction per excitation name (replaces the previous one), added to
        the amplitudes from the next :meth:`step` on."""
        corr = np.zeros(len(self.plant.excitations), complex)
        for name, value in corrections.items():
            value = complex(value)
            if not np.isfinite(value):
                raise ModelError(f"balancer correction {name!r} must be finite (got {value})")
            corr[self._excitation_index(name)] = value
        if not np.array_equal(corr, self._corr):
            self._corr = corr
            self._update_amp()
            self._W = None

    @property
    def amplitudes(self) -> dict[str, complex]:
        """The run's amplitude per excitation (without the balancer's correction)."""
        return {e.name: complex(a) for e, a in zip(self.plant.excitations, self._base_amp)}

    @property
    def correction(self) -> dict[str, complex]:
        return {e.name: complex(c) for e, c in zip(self.plant.excitations, self._corr)}

    # -- per-chunk precomputation --------------------------------------------------------------
    def coefficients(self, speed, accel) -> np.ndarray:
        """Excitation coefficient per force basis and unit amplitude (speed.shape + (nb,))."""
        return basis_coefficients(self.table.bases, speed, accel)

    def _fill(self, k0: int) -> None:
        """Speeds, angles and node lookups of steps ``k0 .. k0 + CHUNK - 1``."""
        T, tab = self.T, self.table
        t = np.arange(k0, k0 + CHUNK + 1) * T
        speed, accel, angle = self.profile.sample(t)
        self._at = list(zip(speed.tolist(), accel.tolist(), angle.tolist()))   # t_k0 .. t_k0+CHUNK
        speed_m, accel_m, _ = self.profile.sample(t[:-1] + 0.5 * T)
        rot = np.exp(1j * angle)[:, None]
        h_meas = self.coefficients(speed, accel) * rot
        # per step k: [w_mid,k | w_meas,k+1] per unit amplitude
        self._h = np.concatenate([self.coefficients(speed_m, accel_m) * rot[:-1], h_meas[1:]],
                                 axis=1)
        self._W = (self._h * self._amp2).view(np.float64)
        self._h0 = h_meas[0]
        i_mid, w_mid = tab.locate(speed_m)
        j_cor, c_cor = tab.slope_interval(speed_m, speed[1:])
        tab.ensure(np.concatenate([i_mid, i_mid[w_mid > 0] + 1]), j_cor[c_cor != 0])
        self._i_mid, self._w_mid = i_mid.tolist(), w_mid.tolist()
        self._j_cor, self._c_cor = j_cor.tolist(), c_cor.tolist()
        moving = (w_mid != 0) | (c_cor != 0)
        self._moving = moving.tolist()
        self._node_or_moving = np.where(moving, -1, i_mid)      # -1: between nodes
        if self.test_force is not None:
            self._d = self.test_force.values(k0, CHUNK).tolist()
        self._k0, self._n_chunk = k0, CHUNK

    # -- the block ----------------------------------------------------------------------------
    def reset(self, x0=None, forces_prev=None) -> np.ndarray:
        """Start at ``t = 0`` in state ``x0`` (default: rest) with ``forces_prev`` (``u_{-1}``,
        default zero) held before; return ``y_0``."""
        lay, v = self._lay, self._v
        v[:] = 0.0
        if x0 is not None:
            v[lay.x] = self._checked(x0, self._N, "initial state")
        if forces_prev is not None:
            v[lay.u] = self._checked(forces_prev, self.n_inputs, "forces")
        self.k = 0
        self._fill(0)
        speed0 = float(self.profile.sample(np.array(0.0))[0])
        R = self.table.measurement(speed0)
        nb = len(self._exc_of_basis)
        w0 = (self._h0 * self._amp2[:nb]).view(np.float64)
        self._y = R @ np.concatenate([v[lay.x], v[lay.u], w0])
        return self._y

    def _checked(self, values, size: int, what: str) -> np.ndarray:
        arr = np.asarray(values, dtype=float).reshape(-1)
        if arr.size != size or not np.all(np.isfinite(arr)):
            raise ModelError(f"{what} must be {size} finite numbers (got {arr.size})")
        return arr

    def step(self, forces) -> np.ndarray:
        """Hold ``forces`` (``u_k``, actuator order of the plant, N) over ``[t_k, t_k+1)``,
        advance to ``x_{k+1}`` and return ``y_{k+1}`` (a new array)."""
        j = self.k - self._k0
        if j >= self._n_chunk:
            self._fill(self.k)
            j = 0
        v = self._v
        v[self._u_slice] = forces
        if self._test_at is not None:
            v[self._test_at] += self._d[j]
        if self._W is None:        # amplitudes changed since the chunk was filled
            np.multiply(self._h[j], self._amp2, out=self._w_both)
        else:
            v[self._w_slice] = self._W[j]
        i = self._i_mid[j]
        out = self.table.BIG[i].dot(v)
        if self._moving[j]:
            out = self._moving_correction(out, j, i)
        N = self._N
        v[:N] = out[:N]
        self.k += 1
        self._y = out[N:]
        return self._y

    def _moving_correction(self, out: np.ndarray, j: int, i: int) -> np.ndarray:
        """Interpolate the step at the midpoint speed, and move the measurement rows from the
        midpoint speed to ``Omega(t_k+1)`` (linearly along the interval, as ``R`` varies)."""
        tab, N = self.table, self._N
        w = self._w_mid[j]
        if w:
            out += w * (tab.BIG[i + 1].dot(self._v) - out)
        c = self._c_cor[j]
        if c:
            out[N:] += c * tab.dRx[self._j_cor[j]].dot(out[:N])
        return out

    # -- steps taken outside (rotor_avc.sim.fused) ----------------------------------------------
    @property
    def excitation_width(self) -> int:
        """Floats of the excitation columns ``[w_mid,k | w_meas,k+1]`` of one step."""
        return self._lay.size - self._lay.w.start

    def steady_steps(self, limit: int):
        """``(node, count, W)``: the next ``count <= limit`` steps all on speed node ``node``
        (none between nodes), inside the precomputed chunk, with its amplitudes and without a
        test force; ``W`` their excitation columns. None when the next step is not such a one."""
        if self.test_force is not None:
            return None
        j = self.k - self._k0
        if j >= self._n_chunk:
            self._fill(self.k)
            j = 0
        node = self._i_mid[j]
        if self._W is None or self._moving[j]:
            return None
        ahead = self._node_or_moving[j:min(self._n_chunk, j + limit)]
        other = np.flatnonzero(ahead != node)
        count = int(other[0]) if other.size else ahead.size
        return node, count, self._W[j:j + count]

    def advance_to(self, steps: int, x, forces_held, y) -> np.ndarray:
        """Take ``steps`` steps computed outside: the state ``x`` and measurement ``y`` they
        reach and the forces held over the last of them. -> ``y`` (a new array)"""
        self._v[self._lay.x] = x
        self._v[self._u_slice] = forces_held
        self.k += steps
        self._y = y.copy()
        return self._y

    # -- inspection ---------------------------------------------------------------------------
    @property
    def time_s(self) -> float:
        return self.k * self.T

    @property
    def state(self) -> np.ndarray:
        """``x_k = [q; q']`` (a copy)."""
        return self._v[self._lay.x].copy()

    def set_state(self, x) -> None:
        """Replace ``x_k`` (of the current sample ``k``): the next :meth:`step` advances from it.
        The measurement ``y_k`` already returned is not recomputed."""
        self._v[self._lay.x] = self._checked(x, self._N, "state")

    @property
    def forces_held(self) -> np.ndarray:
        """``u_{k-1}``, the forces held over the last interval (a copy)."""
        return self._v[self._lay.u].copy()

    def speed_state(self) -> tuple[float, float, float]:
        """``(Omega, Omega', theta)`` at ``t_k`` (from the chunk's precomputed samples)."""
        return self._at[self.k - self._k0]
