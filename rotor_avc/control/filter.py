"""A stateful per-sample IIR filter on plain Python floats (direct form II transposed).

The difference equation ``y_k = b0 x_k + z0``, ``z_i <- b_{i+1} x_k + z_{i+1} - a_{i+1} y_k`` is
the recursion :func:`scipy.signal.lfilter` runs, in the same order of operations, so the two agree
to rounding (tested to 1e-12 over long random inputs). One :meth:`IirFilter.step` costs about a
microsecond for the orders a controller has (no numpy per sample).

The state ``z`` is the observer-canonical realisation with the gain at the input: scaling ``b``
(:meth:`IirFilter.set_gain`) while keeping ``z`` is a bumpless gain change -- the stored part of
the output (integrated force of an I/PI controller) is continuous and only the direct
feed-through ``b0 x`` follows the new gain at once.

:meth:`IirFilter.output` and :meth:`IirFilter.advance` split a step in two so that anti-windup
(:mod:`rotor_avc.control.limits`) can feed the *applied* output back into the recursion.
"""
from __future__ import annotations

import math

from ..errors import ModelError


class IirFilter:
    """``a0 y_k + a1 y_{k-1} + ... = b0 x_k + b1 x_{k-1} + ...`` with explicit state."""

    __slots__ = ("_b_design", "gain", "b", "a", "z", "n")

    def __init__(self, b, a):
        b = [float(v) for v in b]
        a = [float(v) for v in a]
        if not b or not a or not all(math.isfinite(v) for v in b + a):
            raise ModelError(f"filter coefficients must be finite numbers (b = {b}, a = {a})")
        if a[0] == 0.0:
            raise ModelError(f"filter a[0] is zero (a = {a}): not a causal difference equation")
        n = max(len(a), len(b))
        b += [0.0] * (n - len(b))
        a += [0.0] * (n - len(a))
        a0 = a[0]
        self._b_design = tuple(v / a0 for v in b)
        self.a = tuple(v / a0 for v in a)
        self.n = n - 1
        self.gain = 1.0
        self.b = self._b_design
        self.z = [0.0] * self.n

    # -- state -------------------------------------------------------------------------------
    def reset(self) -> None:
        """Zero state (the filter at rest with zero input and output)."""
        self.z = [0.0] * self.n

    @property
    def state(self) -> tuple[float, ...]:
        return tuple(self.z)

    def set_state(self, z) -> None:
        z = [float(v) for v in z]
        if len(z) != self.n or not all(math.isfinite(v) for v in z):
            raise ModelError(f"filter state must be {self.n} finite numbers (got {z})")
        self.z = z

    @property
    def dc_gain(self) -> float:
        """``G(1)``; ``inf`` for an integrating filter (``sum a = 0``)."""
        sa, sb = math.fsum(self.a), math.fsum(self.b)
        scale = math.fsum(abs(v) for v in self.a)
        if abs(sa) <= 1e-12 * scale:
            return math.copysign(math.inf, sb) if sb else 0.0
        return sb / sa

    def init_steady_state(self, x: float, y: float | None = None) -> None:
        """Set the state of a steady state: constant input ``x`` giving constant output ``y``.

        ``y`` defaults to ``G(1) x``. An integrating filter has a steady state only for
        ``x = 0``, with any held output ``y`` (an I controller holding a force). From this state
        the filter outputs ``y`` while the input stays ``x`` (no start-up transient).
        """
        x = float(x)
        sa, sb = math.fsum(self.a), math.fsum(self.b)
        norm_a = math.fsum(abs(v) for v in self.a)
        if y is None:
            if abs(sa) <= 1e-12 * norm_a:
                if x != 0.0:
                    raise ModelError(
                        f"an integrating filter has no steady state for the constant input {x:g} "
                        "(its output ramps) -- start from input 0 and give the held output y")
                y = 0.0
            else:
                y = sb * x / sa
        y = float(y)
        tol = 1e-9 * (norm_a * abs(y) + math.fsum(abs(v) for v in self.b) * abs(x))
        if not math.isfinite(y) or abs(sa * y - sb * x) > tol:
            raise ModelError(f"input {x:g} and output {y:g} are not a steady state of this filter "
                             f"(needs sum(a) y = sum(b) x; G(1) = {self.dc_gain:g})")
        z = [0.0] * self.n
        acc = 0.0
        for i in range(self.n - 1, -1, -1):
            acc += self.b[i + 1] * x - self.a[i + 1] * y
            z[i] = acc
        self.z = z

    def set_gain(self, factor: float) -> None:
        """Scale the designed numerator by ``factor`` keeping the state (bumpless; see module)."""
        factor = float(factor)
        if not math.isfinite(factor):
            raise ModelError(f"gain factor must be finite (got {factor})")
        self.gain = factor
        self.b = tuple(factor * v for v in self._b_design)

    # -- stepping ----------------------------------------------------------------------------
    def step(self, x: float) -> float:
        """One sample: input ``x`` -> output ``y``; advances the state."""
        b, a, z = self.b, self.a, self.z
        n = self.n
        if n == 0:
            return b[0] * x
        y = b[0] * x + z[0]
        if n == 1:
            z[0] = b[1] * x - a[1] * y
        elif n == 2:
            z[0] = b[1] * x + z[1] - a[1] * y
            z[1] = b[2] * x - a[2] * y
        else:
            for i in range(n - 1):
                z[i] = b[i + 1] * x + z[i + 1] - a[i + 1] * y
            z[n - 1] = b[n] * x - a[n] * y
        return y

    def output(self, x: float) -> float:
        """The output for input ``x`` without advancing the state."""
        return self.b[0] * x + (self.z[0] if self.n else 0.0)

    def advance(self, x: float, y_fed_back: float) -> None:
        """Advance the state with input ``x`` and ``y_fed_back`` in the recursion (equal to the
        output for plain filtering; the applied output for anti-windup)."""
        self.z = self.next_state(x, y_fed_back)

    def next_state(self, x: float, y_fed_back: float) -> list[float]:
        """The state :meth:`advance` would produce, without changing the filter."""
        b, a, z, n = self.b, self.a, self.z, self.n
        nz = [0.0] * n
        for i in range(n - 1):
            nz[i] = b[i + 1] * x + z[i + 1] - a[i + 1] * y_fed_back
        if n:
            nz[n - 1] = b[n] * x - a[n] * y_fed_back
        return nz
