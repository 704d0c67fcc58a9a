"""Loop transfer functions and stability margins of the feedback loops, continuous and sampled.

Each controlled actuator ``i`` applies ``u_i = -G_i y_i`` to its measured foot signal ``y_i``
(Werner 2021 eq. 7), so with ``P`` the plant from the actuator forces to the measured signals the
loop matrix broken at the actuator inputs is ``L = diag(G_i) P`` and the closed loop's return
difference is ``I + L``. Continuous design: ``L(jw) = diag(s^k G_c,i) S Z(jw)^-1 P_a`` with the open
plant's dynamic stiffness ``Z`` (:class:`~rotor_avc.closed_loop.loop.ClosedLoop`). Sampled loop:
``L(e^{jwT}) = diag(G_d,i(z) z^-d_i) C (zI - A)^-1 B`` with the exactly discretised plant under the
sampling contract (:meth:`SampledLoop.with_inputs` with the loops open), up to Nyquist ``pi/T``.

Loop ``i`` broken at its actuator input with the other loops closed (the loop-at-a-time loop
transfer of Skogestad & Postlethwaite 2005, *Multivariable Feedback Control*, 2nd ed.: a signal
injected at input ``i`` returns through ``L_ii`` and through the closed loops ``o``)::

    L_i = L_ii - L_io (I + L_oo)^-1 L_oi

and its classical margins (ibid. sec. 2.4.3): phase crossovers ``w_180`` (``L_i`` real negative),
gain margin ``1/|L_i(w_180)|`` (the smallest factor > 1, and the largest < 1 for a conditionally
stable loop), gain crossovers ``|L_i| = 1``, phase margin ``180 deg + arg L_i`` wrapped into
[-180, 180) at the crossover of smallest ``|PM|`` (the convention of MATLAB's and
python-control's ``margin``: negative when ``L_i`` crosses the unit circle with phase lead, then
``|PM|`` more lead reaches -1), sensitivity peak ``Ms = max |1/(1 + L_i)|``. The real axis is
also crossed at the ends: at Nyquist (``L(-1)`` is real) and at ``w = 0`` (``L(0)``, or its limit
where an integrator meets a derivative signal, :func:`_at_zero`).

All loops scaled together by one factor ``g``: the closed loop has a pole on the stability
boundary exactly where ``det(I + g L(jw)) = 0``, i.e. where an eigenvalue (a characteristic locus)
of ``L(jw)`` crosses the negative real axis at ``-1/g`` (generalised Nyquist criterion, MacFarlane
& Postlethwaite 1977, Int. J. Control 25(1)). :func:`gain_margin_frf` returns the nearest such
``g`` below and above 1: the interval around 1 in which stability cannot change, the stable gain
range when the nominal loop is stable (:meth:`SampledLoop.stable_gain_range` from the
eigenvalues gives the same ends).

Disk margin (Seiler, Packard & Gahinet 2020, "An introduction to disk margins", IEEE Control
Systems Magazine 40(5), 78-95; skew sigma = 0, the balanced/symmetric disk):
``alpha = 1 / max_w sigma_max(S - I/2) = 2 / max_w sigma_max(S - T)``, ``S = (I + L)^-1``. For
one loop it is exact; for all loops together the full complex block (sigma_max instead of mu) is
a lower bound of the multiloop disk margin. Gains in ``[(1 - alpha/2)/(1 + alpha/2),
(1 + alpha/2)/(1 - alpha/2)]`` with phases within ``+-2 atan(alpha/2)`` are tolerated.

Crossovers and peaks are refined by root finding (``brentq``) and bounded scalar maximisation on
the brackets of a grid that is logarithmic and dense around every lightly damped pole of the
open, partially and fully closed loops (:attr:`LoopFrf.grid`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.linalg
import scipy.optimize

from ..closed_loop.loop import ClosedLoop
from ..control.spec import FEEDBACK_ORDER, ContinuousController
from ..models.discretize import continuous_state_space
from ..models.plant import LinearPlant
from .sampled_loop import SampledLoop

#: grid points per decade, and per lightly damped pole ``w_d + |sigma| [-6, 6]``
POINTS_PER_DECADE = 300
POLE_POINTS = np.linspace(-6.0, 6.0, 25)
#: solves per batch (bounds the memory of the batched frequency response)
CHUNK = 256
#: local maxima of a peak search refined
PEAKS = 5
#: |Im| / |value| below which a refined crossing counts as on the real axis
REAL_TOL = 1e-6
#: crossings closer to the origin than this fraction of the largest |eigenvalue| on the grid are
#: numerical zeros (e.g. a Tustin zero at Nyquist), not margins
ZERO_TOL = 1e-10


@dataclass(frozen=True, eq=False)
class LoopFrf:
    """A square loop transfer matrix ``L`` as a function of ``w`` (rad/s), for feet ``ids``."""

    ids: tuple[str, ...]
    evaluate: Callable[[np.ndarray], np.ndarray]     # (k,) -> (k, m, m)
    poles_s: np.ndarray                              # s-plane poles (and controller zeros)
    w_max: float                                     # upper end (Nyquist of a sampled loop)
    sample_period_s: float | None = None

    @property
    def nyquist(self) -> bool:
        return self.sample_period_s is not None

    def __call__(self, w) -> np.ndarray:
        w = np.atleast_1d(np.asarray(w, float))
        return np.concatenate([self.evaluate(w[k:k + CHUNK]) for k in range(0, w.size, CHUNK)])

    def grid(self) -> np.ndarray:
        """Log grid (:data:`POINTS_PER_DECADE`) from ``1e-2`` x the slowest pole to
        :attr:`w_max`, with :data:`POLE_POINTS` around every pole ``sigma + j w_d``."""
        mag = np.abs(self.poles_s[np.isfinite(self.poles_s)])
        mag = mag[mag > 1e-9]
        w_lo = min(1e-2 * (mag.min() if mag.size else 1.0), 1e-4 * self.w_max)
        n = int(np.ceil(np.log10(self.w_max / w_lo) * POINTS_PER_DECADE)) + 1
        p = self.poles_s[np.isfinite(self.poles_s) & (self.poles_s.imag > 0)]
        near = (p.imag[:, None] + np.maximum(np.abs(p.real), 1e-6 * p.imag)[:, None]
                * POLE_POINTS).ravel()
        w = np.concatenate([np.logspace(np.log10(w_lo), np.log10(self.w_max), n), near])
        return np.unique(w[(w >= w_lo) & (w <= self.w_max)])

    def single(self, act_id: str) -> "LoopFrf":
        """``L_i`` of one foot with the other loops closed (module docstring)."""
        i = self.ids.index(act_id)
        o = [j for j in range(len(self.ids)) if j != i]

        def evaluate(w):
            L = self.evaluate(w)
            if not o:
                return L
            Loo = L[:, o][:, :, o]
            X = np.linalg.solve(np.eye(len(o)) + Loo, L[:, o][:, :, [i]])
            return L[:, [i]][:, :, [i]] - L[:, [i]][:, :, o] @ X
        return LoopFrf((act_id,), evaluate, self.poles_s, self.w_max, self.sample_period_s)


def continuous_loop_frf(plant: LinearPlant, controllers: dict[str, ContinuousController],
                        speed_rad_s: float, w_F: float) -> LoopFrf:
    """The loop matrix of the continuous design ``G_c(s)`` at one speed and damping frequency,
    up to ``1e3`` x the fastest pole of the open, partially and fully closed loops."""
    ids = tuple(controllers)
    acts = [plant.actuator(i) for i in ids]
    P = np.array([a.force_vector for a in acts]).T                    # (n, m)
    S = np.array([a.sensor_row for a in acts])                        # (m, n)
    open_loop = ClosedLoop(plant, {})

    def evaluate(w):
        s = 1j * w
        X = np.linalg.solve(open_loop.dynamic_stiffness(s, speed_rad_s, w_F), P)
        H = np.stack([c.law(s) for c in controllers.values()], -1)    # s^k G_c
        return H[:, :, None] * (S @ X)

    poles = [scipy.linalg.eigvals(continuous_state_space(plant, speed_rad_s, w_F)[0])]
    for sub in _partial_sets(controllers):
        poles.append(scipy.linalg.eigvals(ClosedLoop(plant, sub).state_space(speed_rad_s, w_F)[0]))
    poles += [np.roots(c.den) for c in controllers.values()]
    poles += [np.roots(c.num) for c in controllers.values() if len(c.num) > 1]
    poles = np.concatenate(poles)
    mag = np.abs(poles[np.isfinite(poles)])
    return LoopFrf(ids, evaluate, poles, 1e3 * max(mag.max(initial=0.0), 1.0))


def _partial_sets(controllers: dict) -> list[dict]:
    """All loops closed, and each set with one loop open."""
    ids = list(controllers)
    subs = [dict(controllers)]
    if len(ids) > 1:
        subs += [{k: controllers[k] for k in ids if k != i} for i in ids]
    return subs


def sampled_loop_frf(loop: SampledLoop, speed_rad_s: float, w_F: float) -> LoopFrf:
    """The loop matrix of a sampled loop (its filters, gain and delays), ``0 < w <= pi/T``."""
    T = loop.sample_period_s
    p = loop.plant
    ids = tuple(loop.controllers)
    names = [f"foot_{i}_{'dva'[FEEDBACK_ORDER[tf.feedback]]}{p.actuator(i).axis}"
             for i, tf in loop.controllers.items()]
    plant_io = SampledLoop(p, {}, {}, T).with_inputs(speed_rad_s, w_F, ids, names)
    A, B, C = plant_io.A, plant_io.B, plant_io.C
    eye = np.eye(A.shape[0])

    def evaluate(w):
        z = np.exp(1j * w * T)
        G = C @ np.linalg.solve(z[:, None, None] * eye - A, B)
        Gd = np.stack([tf(z) * z ** -loop.delay_samples.get(i, 0)
                       for i, tf in loop.controllers.items()], -1)
        return Gd[:, :, None] * G

    z = [scipy.linalg.eigvals(A)]
    for sub in _partial_sets(loop.controllers):
        z.append(scipy.linalg.eigvals(SampledLoop(p, sub, loop.delay_samples, T)
                           .assemble(speed_rad_s, w_F).A))
    z = np.concatenate(z)
    z = z[np.abs(z) > 1e-12]
    return LoopFrf(ids, evaluate, np.log(z.astype(complex)) / T, np.pi / T, T)


# -- crossings and peaks ------------------------------------------------------------------------
def _track(lam: np.ndarray) -> np.ndarray:
    """Eigenvalues (k, m) reordered so that each column follows one locus over the grid."""
    out = lam.copy()
    for k in range(1, lam.shape[0] if lam.shape[1] > 1 else 0):
        cost = np.abs(out[k - 1][:, None] - lam[k][None, :])
        out[k] = lam[k][scipy.optimize.linear_sum_assignment(cost)[1]]
    return out


def _eig(frf: LoopFrf, w: float) -> np.ndarray:
    return np.linalg.eigvals(frf(w)[0])


def real_axis_crossings(frf: LoopFrf, w: np.ndarray,
                        values: np.ndarray) -> list[tuple[float, float]]:
    """``(w, lambda)``: where an eigenvalue of ``L(jw)`` is real and negative (for one loop, the
    phase crossovers), each refined by ``brentq`` on the imaginary part of the tracked locus;
    the real matrices at Nyquist and at ``w = 0`` (:func:`_at_zero`) are checked directly;
    crossings through a numerical zero (:data:`ZERO_TOL`) are left out."""
    lam = _track(np.linalg.eigvals(values))
    scale = np.abs(lam[np.isfinite(lam)]).max(initial=0.0)

    def on_axis(v) -> bool:
        return v.real < -ZERO_TOL * scale and abs(v.imag) <= REAL_TOL * abs(v)
    found = []
    for t in range(lam.shape[1]):
        im, re = lam[:, t].imag, lam[:, t].real
        for k in np.flatnonzero((im[:-1] * im[1:] <= 0) & ((re[:-1] < 0) | (re[1:] < 0))):
            if im[k] == 0 and im[k + 1] == 0:
                continue
            a, b = lam[k, t], lam[k + 1, t]

            def locus(x, k=k, a=a, b=b):
                guess = a + (b - a) * (x - w[k]) / (w[k + 1] - w[k])
                ev = _eig(frf, x)
                return ev[np.argmin(np.abs(ev - guess))]
            x = scipy.optimize.brentq(lambda x: locus(x).imag, w[k], w[k + 1], xtol=1e-13 * w[k],
                                      rtol=4 * np.finfo(float).eps)
            v = locus(x)
            if on_axis(v):
                found.append((float(x), float(v.real)))
    ends = [(frf.w_max, frf(frf.w_max)[0])] if frf.nyquist else []
    dc = _at_zero(frf, w[0])
    if dc is not None:
        ends.append((0.0, dc))
    for x, value in ends:
        for v in np.linalg.eigvals(value):
            # the limit at w = 0 is good to O(w_lo^4): below REAL_TOL it is no crossing
            if on_axis(v) and (x > 0 or v.real < -REAL_TOL * scale):
                found.append((float(x), float(v.real)))
    unique = []
    for x, v in sorted(found):
        if not any(abs(x - y) <= 1e-9 * max(x, 1e-300) and abs(v - u) <= 1e-6 * abs(v)
                   for y, u in unique):
            unique.append((x, v))
    return unique


def _at_zero(frf: LoopFrf, w_lo: float) -> np.ndarray | None:
    """``L(0)``; where it is 0/0 (an integrator meeting a derivative signal: s (1/s), or the
    pole of a digital integrator at z = 1 meeting the zero of a sampled acceleration), its limit
    from ``Re L(jw) = L(0) - w^2 L_2 + O(w^4)`` at ``w_lo`` and ``w_lo/2`` (Richardson); None
    where ``|L|`` grows towards ``w = 0`` (a type-1 loop: no crossing there) or the plant is
    singular (a free body)."""
    try:
        with np.errstate(all="ignore"):
            value = frf(0.0)[0]
        if np.all(np.isfinite(value)):
            return value.real
        L1, L2 = frf(np.array([w_lo, 0.5 * w_lo]))
    except np.linalg.LinAlgError:
        return None
    if np.linalg.norm(L2) > 1.5 * np.linalg.norm(L1):
        return None
    return ((4 * L2 - L1) / 3).real


def _peak(fn: Callable[[float], float], w: np.ndarray, values: np.ndarray) -> tuple[float, float]:
    """``(max fn, w at it)``: the grid's largest local maxima (:data:`PEAKS`, within 10 % of the
    largest), each refined by bounded maximisation between its neighbours."""
    k_max = int(np.argmax(values))
    best = (float(values[k_max]), float(w[k_max]))
    inner = np.flatnonzero((values[1:-1] > values[:-2]) & (values[1:-1] >= values[2:])) + 1
    inner = inner[np.argsort(values[inner])[::-1][:PEAKS]]
    for k in inner[values[inner] >= 0.9 * values[k_max]]:
        res = scipy.optimize.minimize_scalar(lambda x: -fn(x), bounds=(w[k - 1], w[k + 1]),
                                             method="bounded", options={"xatol": 1e-12 * w[k]})
        if -res.fun > best[0]:
            best = (float(-res.fun), float(res.x))
    return best


def _sensitivity_minus_half(L: np.ndarray) -> np.ndarray:
    """``sigma_max(S - I/2)`` of loop matrices ``(k, m, m)``."""
    eye = np.eye(L.shape[-1])
    return np.linalg.norm(np.linalg.inv(eye + L) - 0.5 * eye, ord=2, axis=(-2, -1))


def disk_margin_of(frf: LoopFrf, w: np.ndarray, values: np.ndarray) -> tuple[float, float]:
    """``(alpha, w)``: the balanced disk margin (module docstring) and where it is smallest."""
    peak, w_peak = _peak(lambda x: float(_sensitivity_minus_half(frf(x))[0]), w,
                         _sensitivity_minus_half(values))
    return 1.0 / peak, w_peak


def disk_gain_phase(alpha: float) -> tuple[float, float, float]:
    """``(g_low, g_high, phase_deg)`` tolerated within a balanced disk margin ``alpha``
    (Seiler et al. 2020: the real-axis intercepts of the disk and its phase)."""
    a = 0.5 * alpha
    return max((1 - a) / (1 + a), 0.0), ((1 + a) / (1 - a) if a < 1 else np.inf), float(
        np.degrees(2 * np.arctan(a)))


def gain_range_of(crossings) -> tuple[float, float]:
    """The nearest scaling factors below and above 1 at which a crossing puts a pole on the
    stability boundary: ``-1/lambda`` of each real negative eigenvalue (0 and inf: none)."""
    g = np.array([-1.0 / v for _, v in crossings])
    return (float(g[g < 1].max(initial=0.0)), float(g[g > 1].min(initial=np.inf)))


# -- results -------------------------------------------------------------------------------------
def _sup_hz(frf: LoopFrf, w: np.ndarray, x: float) -> float:
    """``x`` in Hz; inf for a continuous loop's peak at the grid's upper end (approached as
    ``w -> inf``, e.g. ``|S| -> 1`` from below)."""
    return np.inf if not frf.nyquist and x >= w[-1] * (1 - 1e-9) else x / (2 * np.pi)


@dataclass(frozen=True, eq=False)
class Margins:
    """Classical margins of one loop ``L_i`` (module docstring), with its response on the grid."""

    act_id: str
    gain_margin: float            # smallest factor > 1 reaching -1 (inf: none)
    gain_margin_lower: float      # largest factor < 1 reaching -1 (0: none)
    phase_crossover_hz: float     # where gain_margin is read (nan: none)
    phase_margin_deg: float       # of the gain crossover with the smallest |PM| (inf: none)
    crossover_hz: float           # that gain crossover (nan: none)
    sensitivity_peak: float       # Ms
    sensitivity_peak_hz: float
    disk_margin: float            # balanced disk margin alpha of this loop
    phase_crossovers: tuple[tuple[float, float], ...]   # (Hz, gain margin) of every crossing
    gain_crossovers: tuple[tuple[float, float], ...]    # (Hz, phase margin deg) of every one
    w_rad_s: np.ndarray
    response: np.ndarray          # L_i on w_rad_s

    @property
    def gain_margin_db(self) -> float:
        return float(20 * np.log10(self.gain_margin))

    def summary(self) -> dict:
        """The JSON keys of ``rotor-avc controller --json`` (inf and nan stay floats here)."""
        return {"gain_margin": self.gain_margin, "gain_margin_db": self.gain_margin_db,
                "gain_margin_lower": self.gain_margin_lower,
                "phase_margin_deg": self.phase_margin_deg,
                "sensitivity_peak": self.sensitivity_peak,
                "sensitivity_peak_hz": self.sensitivity_peak_hz,
                "crossover_hz": self.crossover_hz, "phase_crossover_hz": self.phase_crossover_hz,
                "disk_margin": self.disk_margin}


def loop_margins(frf: LoopFrf, act_id: str) -> Margins:
    """Margins of foot ``act_id``'s loop with the other loops of ``frf`` closed."""
    one = frf.single(act_id)
    w = one.grid()
    L = one(w)
    ell = L[:, 0, 0]
    crossings = real_axis_crossings(one, w, L)
    lower, upper = gain_range_of(crossings)
    pc = [(x, -1.0 / v) for x, v in crossings]
    f_pc = next((x for x, g in pc if g == upper), np.nan) / (2 * np.pi)
    log_mag = lambda x: float(np.log(np.abs(one(x)[0, 0, 0])))  # noqa: E731
    lm = np.log(np.abs(ell))
    gc = []
    for k in np.flatnonzero(lm[:-1] * lm[1:] < 0):
        x = scipy.optimize.brentq(log_mag, w[k], w[k + 1], xtol=1e-13 * w[k])
        phase = np.degrees(np.angle(one(x)[0, 0, 0]))
        gc.append((x, float(np.remainder(phase, 360.0) - 180.0)))
    pm_w, pm = min(gc, key=lambda c: abs(c[1]), default=(np.nan, np.inf))
    with np.errstate(divide="ignore"):
        ms, ms_w = _peak(lambda x: float(1.0 / np.abs(1.0 + one(x)[0, 0, 0])), w,
                         1.0 / np.abs(1.0 + ell))
    alpha, _ = disk_margin_of(one, w, L)
    hz = lambda x: _sup_hz(one, w, x)  # noqa: E731
    return Margins(act_id, upper, lower, f_pc, pm, hz(pm_w), ms, hz(ms_w), alpha,
                   tuple((hz(x), g) for x, g in pc), tuple((hz(x), p) for x, p in gc), w, ell)


@dataclass(frozen=True, eq=False)
class LoopAnalysis:
    """Every foot's loop margins and the all-loop figures of one loop matrix."""

    loops: dict[str, Margins]
    gain_margin_frf: tuple[float, float]    # (lower, upper) common factor (gain_range_of)
    disk_margin: float                      # all loops, full-block bound (module docstring)
    disk_margin_hz: float

    def summary(self) -> dict:
        lo, hi, phase = disk_gain_phase(self.disk_margin)
        return {"gain_margin_frf": list(self.gain_margin_frf), "disk_margin": self.disk_margin,
                "disk_margin_hz": self.disk_margin_hz, "disk_gain_range": [lo, hi],
                "disk_phase_margin_deg": phase}


def analyse_loop(frf: LoopFrf) -> LoopAnalysis:
    """:func:`loop_margins` of every foot, :func:`gain_margin_frf` and the all-loop disk margin."""
    w = frf.grid()
    L = frf(w)
    alpha, w_alpha = disk_margin_of(frf, w, L)
    return LoopAnalysis({i: loop_margins(frf, i) for i in frf.ids}, gain_margin_frf(frf, w, L),
                        alpha, _sup_hz(frf, w, w_alpha))


def gain_margin_frf(frf: LoopFrf, w: np.ndarray | None = None,
                    values: np.ndarray | None = None) -> tuple[float, float]:
    """``(lower, upper)``: the common factors on all loops nearest below and above 1 at which
    ``det(I + g L(jw)) = 0`` for some ``w`` (0 / inf: none; module docstring); on
    :meth:`LoopFrf.grid` unless ``w`` and ``values = frf(w)`` are given."""
    if w is None:
        w = frf.grid()
        values = frf(w)
    return gain_range_of(real_axis_crossings(frf, w, values))
