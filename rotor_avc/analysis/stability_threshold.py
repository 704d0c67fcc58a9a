"""Threshold of stability of a closed loop with loss-factor damping (Werner 2017, Sec. 3, Fig. 4).

Rotating (internal) damping adds circulatory stiffness ``Omega / w_F N_eta``; above a speed
``Omega_stab`` one eigenvalue of the state matrix (eqs. 11-12) crosses into the right half plane
and the machine whirls at ``omega_stab`` (eq. 13). Loss-factor damping ``d = c tan(delta) / w_F``
(eqs. 2-4) needs the whirl frequency ``w_F = omega_stab`` (eq. 1), which is known only at the end,
so the threshold is a fixed point, found by the paper's loop (Fig. 4):

1. start from an estimate ``w_F`` (Werner 2017: eq. 14);
2. with every damping coefficient frozen at ``w_F``, ``g(Omega) = max_k Re lambda_k`` is scanned on
   a log-spaced speed grid; the threshold is the *first* speed where ``g`` crosses zero: the first
   grid bracket with ``g(lo) < 0 <= g(hi)``, or earlier an instability bubble -- a local maximum
   of a tracked mode's real part that rises above zero between grid points (bounded
   maximisation) -- and the root is refined with ``brentq``;
3. ``omega_stab`` = ``|Im|`` of the eigenvalue with the largest real part at ``Omega_stab``;
   stop when ``|omega_stab - w_F| / w_F < rel_tol`` (the paper's ``Delta``), else ``w_F <-
   omega_stab`` and repeat.

The outcome is a :class:`ThresholdResult` whose ``status`` says what was found; nothing but a
malformed request raises, so parameter grids run unattended. Works for any ``ClosedLoop``
(continuous controllers add their states to the state matrix) and for the sampled loop of
discrete controllers (:class:`SampledEigenvalues`: equivalent poles ``ln(z) / T``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.optimize

from ..errors import ModelError
from ..closed_loop.loop import ClosedLoop

RPM_PER_RAD_S = 30.0 / np.pi

#: the outcomes of :func:`stability_threshold`
STATUSES = {
    "threshold": "unstable above the threshold speed",
    "none_in_range": "stable over the whole speed range",
    "unstable_at_start": "already unstable at the lowest speed of the range",
    "divergence": "the critical eigenvalue is real (no whirl frequency to iterate on)",
    "not_converged": "the whirl-frequency iteration did not settle",
}


@dataclass
class Pass:
    """One pass of the iteration: damping frozen at ``w_F``, the threshold found with it."""

    w_F: float
    speed_rad_s: float | None
    whirl_rad_s: float | None
    critical_mode: int | None


@dataclass
class ThresholdResult:
    """The threshold of stability and how it was found (speeds and frequencies in rad/s)."""

    status: str
    speed_rad_s: float | None
    whirl_rad_s: float | None
    critical_mode: int | None
    w_F: float
    speed_range_rad_s: tuple[float, float]
    history: list[Pass] = field(default_factory=list)
    #: eigenvalue and displacement part of the eigenvector of the critical mode at the threshold
    eigenvalue: complex | None = None
    mode_shape: np.ndarray | None = None

    @property
    def threshold_rpm(self) -> float | None:
        return None if self.speed_rad_s is None else self.speed_rad_s * RPM_PER_RAD_S

    @property
    def converged(self) -> bool:
        return self.status in ("threshold", "none_in_range", "divergence")

    def summary(self) -> dict:
        """``{"threshold_rpm", "whirl_rad_s", "critical_mode"}`` (None where not found)."""
        found = self.status in ("threshold", "divergence")
        return {"threshold_rpm": self.threshold_rpm if found else None,
                "whirl_rad_s": self.whirl_rad_s if found else None,
                "critical_mode": self.critical_mode if found else None}

    def describe(self) -> str:
        lo, hi = (s * RPM_PER_RAD_S for s in self.speed_range_rad_s)
        if self.status == "threshold":
            return (f"threshold of stability {self.threshold_rpm:.1f} rpm, whirl frequency "
                    f"{self.whirl_rad_s:.3f} rad/s ({self.whirl_rad_s / (2 * np.pi):.3f} Hz), "
                    f"critical mode {self.critical_mode}")
        if self.status == "none_in_range":
            return f"stable from {lo:g} to {hi:g} rpm (no threshold in the range)"
        if self.status == "unstable_at_start":
            return f"already unstable at {lo:g} rpm, the lowest speed of the range"
        if self.status == "divergence":
            return (f"divergence (real eigenvalue) at {self.threshold_rpm:.1f} rpm, "
                    f"critical mode {self.critical_mode}")
        return (f"whirl-frequency iteration did not settle in {len(self.history)} passes; last "
                "w_F values " + ", ".join(f"{p.w_F:.2f}" for p in self.history[-4:]) + " rad/s")


# -- eigenvalues over speed ---------------------------------------------------------------------
class StateMatrices:
    """Eigenvalues of a continuous closed loop ``A(Omega; w_F)`` at one damping frequency.

    Without speed-dependent bearing terms ``A`` is affine in ``Omega`` (circulatory and
    gyroscopic terms), so two evaluations of the loop serve every speed."""

    def __init__(self, loop: ClosedLoop, w_F: float, speed_scale_rad_s: float = 1000.0):
        self.loop, self.w_F, self.n = loop, float(w_F), loop.plant.n
        self._affine = loop.plant.speed_terms is None
        if self._affine:
            self._A0 = loop.state_space(0.0, w_F)[0]
            self._A1 = (loop.state_space(speed_scale_rad_s, w_F)[0] - self._A0) / speed_scale_rad_s

    def __call__(self, speeds_rad_s) -> np.ndarray:
        """``A`` for an array of speeds -> (N, m, m)."""
        speeds = np.atleast_1d(np.asarray(speeds_rad_s, dtype=float))
        if self._affine:
            return self._A0 + speeds[:, None, None] * self._A1
        return np.stack([self.loop.state_space(float(s), self.w_F)[0] for s in speeds])

    def eigenvalues(self, speeds_rad_s) -> np.ndarray:
        """All eigenvalues (1/s) over an array of speeds -> (N, m)."""
        return np.linalg.eigvals(self(speeds_rad_s))

    def eig(self, speed_rad_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Eigenvalues and eigenvectors (columns; the first ``n`` rows are ``q``) at one speed."""
        return np.linalg.eig(self(speed_rad_s)[0])

    def max_real_part(self, speeds_rad_s) -> np.ndarray:
        """``g(Omega) = max_k Re lambda_k`` over an array of speeds (1/s)."""
        return self.eigenvalues(speeds_rad_s).real.max(axis=-1)


class SampledEigenvalues:
    """Equivalent continuous poles ``s = ln(z) / T`` of a sampled loop
    (:class:`rotor_avc.analysis.sampled_loop.SampledLoop`, DESIGN.md 3) at one damping frequency:
    the same threshold procedure then finds where a pole leaves the unit circle. Frequencies are
    unique below the Nyquist frequency only (higher modes alias)."""

    def __init__(self, loop, w_F: float):
        self.loop, self.w_F, self.n = loop, float(w_F), loop.plant.n
        self.T = loop.sample_period_s

    def _s(self, z: np.ndarray) -> np.ndarray:
        z = np.where(np.abs(z) < 1e-200, 1e-200, z).astype(complex)      # delay lines: z = 0
        return np.log(z) / self.T

    def eigenvalues(self, speeds_rad_s) -> np.ndarray:
        z = [self.loop.poles(float(s), self.w_F).z for s in np.atleast_1d(speeds_rad_s)]
        if len({zk.size for zk in z}) != 1:
            raise ModelError("the sampled loop's drift eigenvalues (z = 1) could not be separated "
                             "consistently over speed -- check the controllers' integrators")
        return self._s(np.array(z))

    def eig(self, speed_rad_s: float) -> tuple[np.ndarray, np.ndarray]:
        z, vec = np.linalg.eig(self.loop.assemble(float(speed_rad_s), self.w_F).A)
        keep = np.ones(z.size, bool)
        for d in self.loop.poles(float(speed_rad_s), self.w_F).drift:     # split off as poles() does
            keep[np.argmin(np.where(keep, np.abs(z - d), np.inf))] = False
        return self._s(z[keep]), vec[:, keep]

    def max_real_part(self, speeds_rad_s) -> np.ndarray:
        return self.eigenvalues(speeds_rad_s).real.max(axis=-1)


def eigen_source(loop, w_F: float, speed_scale_rad_s: float = 1000.0):
    """The eigenvalue provider of a continuous ``ClosedLoop`` or a sampled loop."""
    if isinstance(loop, ClosedLoop):
        return StateMatrices(loop, w_F, speed_scale_rad_s)
    return SampledEigenvalues(loop, w_F)


def mode_number(eigenvalues: np.ndarray, index: int) -> int:
    """1-based mode number of ``eigenvalues[index]``: oscillating modes counted by ascending
    damped natural frequency ``|Im|``, one per conjugate pair, as the paper numbers its critical
    "mode 3"; 0 for a real (non-oscillating) eigenvalue."""
    scale = max(np.abs(eigenvalues).max(), 1.0)
    freq = np.abs(eigenvalues[index].imag)
    if freq <= 1e-9 * scale:
        return 0
    upper = eigenvalues.imag[eigenvalues.imag > 1e-9 * scale]
    return 1 + int(np.count_nonzero(upper < freq - 1e-12 * scale))


def critical_mode(source, speed_rad_s: float):
    """``(eigenvalue, mode number, displacement eigenvector)`` of the least damped mode."""
    lam, vec = source.eig(speed_rad_s)
    k = int(np.argmax(lam.real))
    n = source.n
    shape = vec[:n, k] if lam[k].imag >= 0 else np.conj(vec[:n, k])
    shape = shape / shape[np.argmax(np.abs(shape))]
    return complex(lam[k].real, abs(lam[k].imag)), mode_number(lam, k), shape


def track_modes(eigenvalues: np.ndarray) -> np.ndarray:
    """Reorder the columns of eigenvalues over speed (N, m) so that each follows one mode:
    nearest-neighbour assignment between neighbouring speeds."""
    out = np.empty_like(eigenvalues)
    out[0] = eigenvalues[0]
    for i in range(1, len(eigenvalues)):
        _, cols = scipy.optimize.linear_sum_assignment(
            np.abs(out[i - 1][:, None] - eigenvalues[i][None, :]))
        out[i] = eigenvalues[i][cols]
    return out


def first_crossing(source, grid_rad_s: np.ndarray) -> tuple[str, float | None]:
    """The first speed of ``grid_rad_s``'s range where ``g`` reaches zero, with the damping
    frozen at ``source.w_F`` -> ``("threshold", speed)``, ``("none_in_range", None)`` or
    ``("unstable_at_start", lowest speed)``.

    Besides the first grid bracket of ``g``, every local maximum of a tracked mode's real part
    before it is checked by bounded maximisation: an instability bubble narrower than the grid
    spacing, or hidden on the grid under another mode's larger real part, is still found."""
    lam = track_modes(source.eigenvalues(grid_rad_s))
    g = lam.real.max(axis=1)
    if g[0] >= 0.0:
        return "unstable_at_start", float(grid_rad_s[0])
    cross = np.flatnonzero((g[:-1] < 0.0) & (g[1:] >= 0.0))
    end = int(cross[0]) if cross.size else len(g) - 1
    lo = hi = None
    rise = 1e-9 * max(np.abs(lam).max(), 1.0)        # ignore round-off wiggles of flat curves
    alpha = lam.real
    peaks = [(i, k) for i in range(1, min(end + 1, len(g) - 1)) for k in range(lam.shape[1])
             if lam[i, k].imag >= 0.0 and alpha[i, k] > alpha[i - 1, k] + rise
             and alpha[i, k] >= alpha[i + 1, k]]
    for i, k in peaks:                               # ascending speed
        peak = _bubble_peak(source, grid_rad_s[i - 1:i + 2], lam[i - 1:i + 2, k])
        if peak is not None:
            lo, hi = grid_rad_s[i - 1], peak
            break
    if lo is None and cross.size:
        lo, hi = grid_rad_s[end], grid_rad_s[end + 1]
    if lo is None:
        return "none_in_range", None
    speed = scipy.optimize.brentq(lambda x: float(source.max_real_part(x)[0]), lo, hi,
                                  xtol=1e-10 * hi, rtol=1e-12, maxiter=200)
    return "threshold", float(speed)


def _bubble_peak(source, speeds: np.ndarray, mode: np.ndarray) -> float | None:
    """Speed within ``speeds[0] .. speeds[2]`` where the mode sampled as ``mode`` at ``speeds``
    has a positive real part (the eigenvalue nearest to the interpolated one), if any."""
    def real_part(x):
        guess = np.interp(x, speeds, mode.real) + 1j * np.interp(x, speeds, mode.imag)
        lam = source.eigenvalues(x)[0]
        return float(lam[np.argmin(np.abs(lam - guess))].real)

    res = scipy.optimize.minimize_scalar(lambda x: -real_part(x), bounds=(speeds[0], speeds[2]),
                                         method="bounded", options={"xatol": 1e-7 * speeds[2]})
    return float(res.x) if -res.fun >= 0.0 else None


def stability_threshold(loop, w_F_start: float, speed_min_rad_s: float,
                        speed_max_rad_s: float, n_grid: int = 200, rel_tol: float = 1e-6,
                        max_iter: int = 50) -> ThresholdResult:
    """The paper's threshold procedure (Fig. 4); see the module docstring.

    ``loop`` is a continuous ``ClosedLoop`` or a sampled loop (``SampledLoop``: threshold where a
    pole leaves the unit circle); ``w_F_start`` is the first damping frequency (rad/s; Werner 2017:
    eq. 14), the speed range is scanned on ``n_grid`` log-spaced speeds, ``rel_tol`` is the
    paper's ``Delta``."""
    if not (np.isfinite(w_F_start) and w_F_start > 0):
        raise ModelError(f"the start value of the whirl frequency must be > 0 (got {w_F_start})")
    if not (0 < speed_min_rad_s < speed_max_rad_s and np.isfinite(speed_max_rad_s)):
        raise ModelError(f"the speed range must satisfy 0 < min < max (got {speed_min_rad_s}, "
                         f"{speed_max_rad_s} rad/s)")
    if n_grid < 3 or max_iter < 1 or not rel_tol > 0:
        raise ModelError("need n_grid >= 3, max_iter >= 1 and rel_tol > 0")
    grid = np.geomspace(speed_min_rad_s, speed_max_rad_s, n_grid)
    rng = (float(speed_min_rad_s), float(speed_max_rad_s))
    w_F = float(w_F_start)
    history: list[Pass] = []
    for _ in range(max_iter):
        source = eigen_source(loop, w_F, speed_max_rad_s)
        status, speed = first_crossing(source, grid)
        if status == "none_in_range":
            history.append(Pass(w_F, None, None, None))
            return ThresholdResult(status, None, None, None, w_F, rng, history)
        lam, mode, shape = critical_mode(source, speed)
        whirl = abs(lam.imag)
        history.append(Pass(w_F, speed, whirl, mode))
        if status == "unstable_at_start":
            return ThresholdResult(status, speed, whirl, mode, w_F, rng, history, lam, shape)
        if mode == 0:
            return ThresholdResult("divergence", speed, 0.0, mode, w_F, rng, history, lam, shape)
        if abs(whirl - w_F) < rel_tol * w_F:
            return ThresholdResult(status, speed, whirl, mode, w_F, rng, history, lam, shape)
        w_F = whirl
    last = history[-1]
    return ThresholdResult("not_converged", last.speed_rad_s, last.whirl_rad_s, last.critical_mode,
                           w_F, rng, history)


# -- Campbell diagram ---------------------------------------------------------------------------
def eigenvalues_over_speed(loop, speeds_rad_s, w_F: float) -> np.ndarray:
    """Eigenvalues over speed with the damping frozen at ``w_F``, tracked (column ``k`` follows
    one mode) -> (N, modes): one eigenvalue of each conjugate pair (``Im > 0``) and the real
    ones."""
    speeds = np.asarray(speeds_rad_s, dtype=float)
    lam = eigen_source(loop, w_F, max(speeds.max(), 1.0)).eigenvalues(speeds)
    out = track_modes(lam[:, np.lexsort((lam[0].real, lam[0].imag))])
    return out[:, out.imag.max(axis=0) >= 0.0]
