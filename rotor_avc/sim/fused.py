"""The lockstep loop's fast path: plant and linear controllers in one matrix per sample.

While the speed sits on one node of the stepper's table and every controller runs linearly
(its measurement plausible, its force inside the force and rate limits, finite), the whole
sample ``k -> k+1`` of :func:`rotor_avc.sim.loop.run_blocks` is linear in
``[w_k | x_k | u_k | z_k+1]`` (the rotating excitation's columns, the plant state, the held
forces, every controller filter's state)::

    x_k+1 = S [x_k | u_k | w_mid,k]                     (the stepper's step matrix, BIG)
    y_k+1 = R [x_k+1 | u_k | w_meas,k+1]
    u_k+1 = -(b0 s_k+1 + z_0)                           s = the controller's signal in y_k+1
    z_i  <- (b_i+1 - a_i+1 b0) s_k+1 + z_i+1 - a_i+1 z_0   (direct form II transposed,
                                                          rotor_avc.control.filter)

so one product of a fused matrix with that row gives ``[x_k+1 | u_k+1 | z_k+2 | y_k+1]``
written straight into the next row of a buffer whose ``w`` columns are the stepper's
precomputed excitation: one mat-vec per sample and no other Python work.

Anything the fused product cannot represent is handled by exception: after a segment, the
rows are checked at once (each controller's signal within its ``measurement_limit``, force
strictly inside ``force_limit_n``, step within the rate limit, finite); from the first row that
breaks one, the run goes back to the blocks' own per-sample path (which rejects, limits, winds
back and counts exactly as without the fast path), and tries the fast path again later.
Controllers with a delay line, other block kinds (feed-forward, harmonic, balancer), a
broadband test force, changed amplitudes and samples between speed nodes always take the
per-sample path. The two agree to rounding (tested to 1e-12 of the signals' peak).
"""
from __future__ import annotations

import numpy as np

from ..control.block import DigitalController
from .stepper import CHUNK, PlantStepper

#: shortest segment worth the set-up; after a broken row, this many samples per-sample first
MIN_SEGMENT = 16
BACK_OFF = 64


def fusable(controllers) -> bool:
    """Whether every controller is a linear :class:`DigitalController` without a delay line."""
    return all(type(c) is DigitalController and c.delay_samples == 0
               for c in controllers)


class FusedLoop:
    """The fast path over one stepper and its controllers' plan (``control_plan``)."""

    def __init__(self, stepper: PlantStepper, plan, n_steps: int = CHUNK):
        """``n_steps``: the run's length (a shorter run needs fewer buffer rows than a chunk)."""
        self.stepper, self.plan = stepper, plan
        self.N, self.m = 2 * stepper.plant.n, stepper.n_inputs
        self.ny = len(stepper.layout.names)
        self.nw = stepper.excitation_width
        orders = [ctrl.filter.n for _, ctrl, _ in plan]
        self.z_at = np.cumsum([0] + orders)[:-1].tolist()       # each filter's first state
        self.nz = sum(orders)
        self.width_in = self.nw + self.N + self.m + self.nz
        width = self.width_in + self.ny
        self.x = slice(self.nw, self.nw + self.N)
        self.u = slice(self.x.stop, self.x.stop + self.m)
        self.z = slice(self.u.stop, self.u.stop + self.nz)
        self.y = slice(self.z.stop, width)
        self.rows = np.zeros((min(CHUNK, n_steps) + 1, width))
        self._in = [row[:self.width_in] for row in self.rows]
        self._out = [row[self.nw:] for row in self.rows]
        self._matrices: dict[int, np.ndarray] = {}
        pos = [p for p, _, _ in plan]
        self._signal_columns = self.y.start + np.array([i for _, _, i in plan], dtype=int)
        self._force_columns = self.u.start + np.array(pos, dtype=int)
        ctrls = [c for _, c, _ in plan]
        self._meas_limit = np.array([c.measurement_limit for c in ctrls])
        self._force_limit = np.array([c.limits.force_limit_n for c in ctrls])
        self._max_step = np.array([c.limits.max_step_n for c in ctrls])
        self.skip = 0
        self._next = self._done = 0

    def matrix(self, node: int) -> np.ndarray:
        """The fused matrix of speed node ``node`` (module docstring), built once."""
        F = self._matrices.get(node)
        if F is not None:
            return F
        st, N, m, nw = self.stepper, self.N, self.m, self.nw
        big = st.table.BIG[node]
        F = np.zeros((self.width_in + self.ny - nw, self.width_in))
        cols = np.r_[N + m:N + m + nw, 0:N, N:N + m]           # BIG's [x|u|w] as [w|x|u]
        F[:N, :nw + N + m] = big[:N, cols]
        y_rows = big[N:, cols]
        F[N + m + self.nz:, :nw + N + m] = y_rows
        z0 = nw + N + m
        for (pos, ctrl, sig), at in zip(self.plan, self.z_at):
            b, a, n = ctrl.filter.b, ctrl.filter.a, ctrl.filter.n
            signal = np.zeros(self.width_in)
            signal[:nw + N + m] = y_rows[sig]
            F[N + pos] = -b[0] * signal
            if n:
                F[N + pos, z0 + at] -= 1.0
            for i in range(n):
                row = F[N + m + at + i]
                row += (b[i + 1] - a[i + 1] * b[0]) * signal
                row[z0 + at] -= a[i + 1]
                if i + 1 < n:
                    row[z0 + at + i + 1] += 1.0
        self._matrices[node] = F
        return F

    @property
    def pending(self) -> bool:
        """Samples done on the fast path and not yet handed out (:meth:`emit`)."""
        return self._next < self._done

    def run(self, y: np.ndarray, u: list, Y: np.ndarray, U: np.ndarray, j: int, stop: int,
            left: int) -> tuple[int, np.ndarray]:
        """Samples ``k, k+1, ...`` on the fast path from ``y = y_k`` and ``u = u_k`` (the
        controllers having just answered ``y_k`` on their own path), to the end of the stepper's
        chunk, of the run (``left`` samples) or the first sample it cannot represent -- never cut
        by the caller's blocks, so the numbers do not depend on them. Leaves the stepper and the controllers at the first sample
        not done and hands out the first ones (:meth:`emit`); returns how many it handed out
        (0: none done, take the per-sample path) and that first sample's measurement."""
        if self.skip:
            self.skip -= 1
            return 0, y
        found = self.stepper.steady_steps(left)
        if found is None or found[1] < MIN_SEGMENT:
            return 0, y
        node, count, W = found
        rows, nw = self.rows, self.nw
        rows[:count, :nw] = W
        first = rows[0]
        first[self.x] = self.stepper.state
        first[self.u] = u
        first[self.y] = y
        zs = first[self.z]
        for (_, ctrl, _), at in zip(self.plan, self.z_at):
            zs[at:at + ctrl.filter.n] = ctrl.filter.z
        F, dot = self.matrix(node), np.dot
        for src, dst in zip(self._in[:count], self._out[1:count + 1]):
            dot(F, src, out=dst)
        done = self._first_broken(count)
        if done < MIN_SEGMENT:
            self.skip = BACK_OFF
        self._next, self._done = 0, done
        y = self._leave_at(done)
        return self.emit(Y, U, j, stop), y

    def emit(self, Y: np.ndarray, U: np.ndarray, j: int, stop: int) -> int:
        """Record the samples done and not yet handed out into rows ``j ..`` (before ``stop``)
        of ``Y`` and ``U``; -> how many."""
        a = self._next
        n = min(self._done - a, stop - j)
        Y[j:j + n] = self.rows[a:a + n, self.y]
        U[j:j + n] = self.rows[a:a + n, self.u]
        self._next = a + n
        return n

    def _first_broken(self, count: int) -> int:
        """The first row 1..count whose controller step the fused product cannot represent
        (``count`` if none)."""
        rows = self.rows[:count + 1]
        signals = rows[1:, self._signal_columns]
        forces = rows[:, self._force_columns]
        broken = ~(np.abs(signals) <= self._meas_limit)            # also NaN
        broken |= ~(np.abs(forces[1:]) < self._force_limit)
        broken |= np.abs(np.diff(forces, axis=0)) > self._max_step
        bad = np.flatnonzero(broken.any(axis=1))
        return int(bad[0]) + 1 if bad.size else count

    def _leave_at(self, done: int) -> np.ndarray:
        """The stepper at sample ``k + done`` (state and measurement of row ``done``), every
        controller as its own path leaves it after answering sample ``k + done - 1``."""
        rows = self.rows
        y = self.stepper.advance_to(done, rows[done, self.x], rows[done - 1, self.u],
                                    rows[done, self.y])
        last = rows[done - 1]
        for (pos, ctrl, _), at in zip(self.plan, self.z_at):
            force = float(last[self.u.start + pos])
            ctrl.filter.z = last[self.z.start + at:self.z.start + at + ctrl.filter.n].tolist()
            ctrl.last_force_n = force
            ctrl.limits.last = -force
        return y
