"""The fit: sensitivities first, then a bounded nonlinear least-squares fit of the identifiable
parameters, then how sure it is.

1. **Sensitivities.** The Jacobian of the weighted residual in the normalised parameters
   ``z = value / reference`` by forward differences (step ``1e-6 max(|z|, 1e-3)``, taken
   backwards at an upper bound), each column a point of the study engine
   (rotor_avc.studies: in this process, local processes or a Dask cluster; the residual is a pure
   function, so every backend gives the same bits).
2. **Screening.** At the configured values, with the measured uncertainty alone (reduced
   chi-square 1): a parameter whose 10 % change moves the weighted residual (the channels'
   calibration gains profiled out, rotor_avc.calibration.problem) by less than two standard
   deviations is *insensitive* (its effect does not tell from the noise and the sensors'
   calibration at 95 %); of two whose estimates correlate beyond 0.95 the less sensitive
   is *collinear* with the other; a parameter whose standard deviation exceeds 10 % of its
   value (several nearly collinear together) is *poorly determined*. Those keep their configured
   values, are reported ``identifiable: false`` with the reason, and are not fitted.
3. **Fit.** scipy's trust-region reflective least squares (``least_squares(method="trf")``,
   Branch, Coleman & Li 1999) inside the bounds, from the configured values; with ``starts``
   more seeded starts (log-uniform inside positive bounds, uniform otherwise; start ``k`` from
   ``SeedSequence(seed, spawn_key=(k,))``) each fitted on the study engine, the lowest cost
   kept. A fit stopped by its evaluation budget has not converged and is refused.
4. **How sure.** At the optimum the covariance ``s^2 (J^T J)^-1`` with ``s^2`` the reduced
   chi-square of the residual, but at least 1 (a model error widens the intervals; they are
   never narrower than the stated measurement uncertainty gives), standard deviations, the
   95 % intervals ``value +- t(0.975, m - n) std`` (Student's t, ``m`` residuals, ``n``
   parameters) and the correlation matrix. A fitted parameter is *identifiable* when its 95 %
   interval lies within ``identified_within`` (default 2 %) of its value and it correlates with
   no other beyond 0.95; else it is reported *uncertain* (``identifiable: false``) with its
   value and interval -- the fit's value is kept, but not presented as known.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize
import scipy.stats

from ..errors import ModelError
from ..studies.engine import run_study
from ..studies.spec import StudySpec
from .problem import Columns, FitEvaluator, Problem, ResidualEvaluator, Starts

#: a change of this fraction of a parameter must move the weighted residual by DETECTABLE
#: standard deviations
SENSITIVITY_CHANGE = 0.1
DETECTABLE = 2.0
MAX_CORRELATION = 0.95
MAX_RELATIVE_STD = 0.1
#: a fitted parameter is identified when its 95 % interval lies within this fraction of it
IDENTIFIED_WITHIN = 0.02
RELATIVE_STEP = 1e-6
MAX_EVALUATIONS = 200
CONFIDENCE = 0.95


@dataclass
class Screen:
    """Which parameters the data determine, and why not the others."""

    free: list[int]
    reasons: dict[int, str]
    #: change of the weighted residual, in standard deviations, per 100 % change
    sensitivity: np.ndarray


@dataclass
class Fit:
    """The outcome (values in the parameters' units; ``std`` and ``ci95`` ``None`` where not
    fitted)."""

    values: np.ndarray
    std: list
    ci95: list
    correlation: np.ndarray
    identifiable: list[bool]
    reasons: list[str]
    sensitivity: np.ndarray
    condition: float
    chi2_before: float
    chi2_after: float
    dof: int
    evaluations: int
    starts: list[dict] = field(default_factory=list)
    #: the Jacobian of the weighted residual at the configured values per 100 % change of each
    #: parameter (every parameter)
    jacobian: np.ndarray | None = None
    elapsed_s: float = 0.0
    #: fitted (the screening kept it): identifiable, or uncertain with its interval
    fitted: list[bool] = field(default_factory=list)


def steps(z: np.ndarray, upper: np.ndarray) -> np.ndarray:
    h = RELATIVE_STEP * np.maximum(np.abs(z), 1e-3)
    return np.where(z + h > upper, -h, h)


def jacobian(problem: Problem, z, free, r0, upper, backend=None,
             batch_size: int | None = None) -> np.ndarray:
    """Columns ``free`` of the Jacobian of the scaled residual at ``z`` (``r0`` the residual
    there), each column a point of the study engine on ``backend`` (default: serial;
    ``batch_size`` columns per task, default as the engine chooses)."""
    z = np.asarray(z, float)
    h = steps(z, upper)
    idx = list(free)
    cols = Columns(tuple(float(v) for v in z), tuple(float(v) for v in h), tuple(idx))
    spec = StudySpec(cols, ResidualEvaluator(problem))
    run = run_study(spec, backend, batch_size=batch_size, progress=False)
    if run.failed:
        raise ModelError(f"the model could not be evaluated near the parameters "
                         f"({run.failed[0].error})")
    return np.column_stack([(o.record["residual"] - r0) / h[j]
                            for o, j in zip(run.outcomes, idx)])


def _covariance(J: np.ndarray, s2: float) -> np.ndarray:
    U, sv, Vt = np.linalg.svd(J, full_matrices=False)
    keep = sv > sv[0] * 1e-12 if sv.size else sv.astype(bool)
    inv = np.where(keep, 1.0 / np.where(keep, sv, 1.0) ** 2, np.inf)
    return s2 * (Vt.T * inv) @ Vt


def _condition(J: np.ndarray) -> float:
    norms = np.linalg.norm(J, axis=0)
    if J.size == 0 or np.any(norms == 0):
        return float("inf")
    sv = np.linalg.svd(J / norms, compute_uv=False)
    return float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")


def screen(J: np.ndarray, z: np.ndarray, labels: list[str], s2: float = 1.0) -> Screen:
    """The rules of step 2 (module docstring) on the columns of ``J``."""
    free = list(range(J.shape[1]))
    sens = np.linalg.norm(J, axis=0) * np.where(z != 0, np.abs(z), 1.0) / np.sqrt(s2)
    reasons: dict[int, str] = {}
    for j in list(free):
        if SENSITIVITY_CHANGE * sens[j] < DETECTABLE:
            reasons[j] = (f"insensitive: a {SENSITIVITY_CHANGE:.0%} change moves the weighted "
                          f"residual by {SENSITIVITY_CHANGE * sens[j]:.2g} standard deviations "
                          f"(below the noise and the sensors' calibration: {DETECTABLE:g} "
                          "needed)")
            free.remove(j)
    while len(free) > 1:
        cov = _covariance(J[:, free], s2)
        std = np.sqrt(np.diag(cov))
        corr = cov / np.outer(std, std)
        np.fill_diagonal(corr, 0.0)
        a, b = np.unravel_index(np.argmax(np.abs(corr)), corr.shape)
        if abs(corr[a, b]) <= MAX_CORRELATION:
            break
        drop, keep = (a, b) if sens[free[a]] < sens[free[b]] else (b, a)
        reasons[free[drop]] = (f"collinear with {labels[free[keep]]} (correlation "
                               f"{corr[a, b]:+.3f}): the data determine only a combination")
        free.pop(drop)
    while free:
        scale = np.where(z[free] != 0, np.abs(z[free]), 1.0)
        rel = np.sqrt(np.diag(_covariance(J[:, free], s2))) / scale
        worst = int(np.argmax(rel))
        if rel[worst] <= MAX_RELATIVE_STD:
            break
        reasons[free[worst]] = (f"poorly determined: standard deviation {rel[worst]:.0%} of the "
                                f"value (> {MAX_RELATIVE_STD:.0%})")
        free.pop(worst)
    return Screen(free, reasons, sens)


class _Cached:
    """The scaled residual with the last values remembered (the Jacobian's base point)."""

    def __init__(self, problem: Problem, z_full: np.ndarray, free: list[int]):
        self.problem, self.z, self.free = problem, z_full.copy(), list(free)
        self.evaluations = 0
        self.last: tuple[bytes, np.ndarray] | None = None

    def full(self, x) -> np.ndarray:
        z = self.z.copy()
        z[self.free] = x
        return z

    def __call__(self, x) -> np.ndarray:
        key = np.asarray(x, float).tobytes()
        if self.last is None or self.last[0] != key:
            self.evaluations += 1
            self.last = (key, self.problem.scaled_residual(self.full(x)))
        return self.last[1]


def local_fit(problem: Problem, z0: np.ndarray, free, bounds, backend=None, report=None,
              batch_size: int | None = None):
    """Trust-region reflective fit of the ``free`` normalised parameters from ``z0`` inside
    ``bounds`` (normalised ``(lower, upper)`` arrays); returns scipy's result with ``x`` the
    whole normalised vector and ``nfev`` counting the Jacobians' evaluations too."""
    free = list(free)
    fun = _Cached(problem, np.asarray(z0, float), free)
    lo, hi = bounds
    columns = [0]

    def jac(x):
        z = fun.full(x)
        J = jacobian(problem, z, free, fun(x), hi, backend, batch_size)
        columns[0] += len(free)
        if report is not None:
            report(fun.evaluations + columns[0], float(0.5 * fun(x) @ fun(x)))
        return J

    x0 = np.clip(np.asarray(z0, float)[free], lo[free], hi[free])
    result = scipy.optimize.least_squares(fun, x0, jac=jac, bounds=(lo[free], hi[free]),
                                          method="trf", x_scale="jac", max_nfev=MAX_EVALUATIONS,
                                          ftol=1e-10, xtol=1e-10, gtol=1e-10)
    result.x = fun.full(result.x)
    result.nfev = fun.evaluations + columns[0]
    return result


def start_points(bounds, z0: np.ndarray, count: int, seed: int) -> list[np.ndarray]:
    """The configured start and ``count`` seeded draws inside the bounds (module docstring)."""
    lo, hi = bounds
    out = [z0.copy()]
    for k in range(count):
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(k,)))
        z = z0.copy()
        for j in range(z.size):
            a, b = lo[j], min(hi[j], 1e6 * max(abs(z0[j]), 1.0))
            z[j] = (np.exp(rng.uniform(np.log(a), np.log(b))) if a > 0
                    else rng.uniform(a, b))
        out.append(z)
    return out


def calibrate(problem: Problem, backend=None, starts: int = 0, seed: int = 0,
              report=None, batch_size: int | None = None,
              identified_within: float = IDENTIFIED_WITHIN) -> Fit:
    """Steps 1-4 of the module docstring."""
    t0 = time.perf_counter()
    params = problem.params
    labels = [p.label for p in params]
    ref = problem.reference
    bounds = (np.array([p.lower for p in params]) / ref, np.array([p.upper for p in params]) / ref)
    z0 = problem.initial / ref
    r0 = problem.scaled_residual(z0)
    J0 = jacobian(problem, z0, range(len(params)), r0, bounds[1], backend, batch_size)
    first = screen(J0, z0, labels)
    reasons = dict(first.reasons)
    free = list(first.free)
    if not free:
        raise ModelError("no parameter is identifiable from these recordings: " + "; ".join(
            f"{labels[j]}: {why}" for j, why in sorted(reasons.items())))
    best, tried = _best_fit(problem, z0, free, bounds, backend, starts, seed, report,
                            batch_size)
    evaluations = 1 + len(params) + sum(t["nfev"] for t in tried)
    z = best
    r = problem.scaled_residual(z)
    J = jacobian(problem, z, free, r, bounds[1], backend, batch_size)
    evaluations += 1 + len(free)
    dof = max(r.size - len(free), 1)
    chi2 = float(r @ r / dof)
    cov = _covariance(J, max(chi2, 1.0))
    std_z = np.sqrt(np.diag(cov))
    corr = np.full((len(params), len(params)), np.nan)
    corr[np.ix_(free, free)] = cov / np.outer(std_z, std_z)
    t = float(scipy.stats.t.ppf(0.5 + CONFIDENCE / 2, dof))
    values = z * ref
    std, ci = [None] * len(params), [None] * len(params)
    for k, j in enumerate(free):
        std[j] = float(std_z[k] * ref[j])
        ci[j] = [float(values[j] - t * std[j]), float(values[j] + t * std[j])]
        others = [(abs(corr[j, i]), i) for i in free if i != j]
        worst, other = max(others) if others else (0.0, j)
        half = t * std[j] / abs(values[j]) if values[j] != 0 else np.inf
        if worst > MAX_CORRELATION:
            reasons[j] = (f"uncertain: correlates with {labels[other]} ({corr[j, other]:+.3f}) "
                          "at the fitted values")
        elif half > identified_within:
            reasons[j] = (f"uncertain: its 95 % interval is +-{half:.2%} of the value (more "
                          f"than +-{identified_within:.2%})")
    return Fit(values, std, ci, corr, [j in free and j not in reasons for j in range(len(params))],
               [reasons.get(j, "") for j in range(len(params))], first.sensitivity,
               _condition(J), float(r0 @ r0 / max(r0.size - len(free), 1)), chi2, dof,
               evaluations, tried, J0 * np.where(z0 != 0, np.abs(z0), 1.0),
               time.perf_counter() - t0, [j in free for j in range(len(params))])


def _best_fit(problem, z0, free, bounds, backend, starts, seed, report, batch_size):
    """The lowest-cost fit of the configured start and ``starts`` seeded ones."""
    fixed = z0.copy()
    results = []
    main = local_fit(problem, fixed, free, bounds, backend, report, batch_size)
    results.append({"start": 0, "z": main.x, "cost": float(main.cost),
                    "status": int(main.status), "nfev": int(main.nfev)})
    if starts:
        points = start_points(bounds, fixed, starts, seed)[1:]
        spec = StudySpec(Starts(tuple(tuple(p) for p in points)),
                         FitEvaluator(problem, local_fit, tuple(free), bounds))
        run = run_study(spec, backend, batch_size=batch_size, progress=False)
        for o in run.outcomes:
            if o.error is None:
                results.append({"start": o.index + 1, **o.record})
            else:
                results.append({"start": o.index + 1, "error": o.error, "cost": np.inf,
                                "status": -1, "nfev": 0})
    converged = [r for r in results if r["status"] > 0]
    if not converged:
        raise ModelError(f"the fit did not converge within {MAX_EVALUATIONS} evaluations "
                         f"(cost {results[0]['cost']:.4g}); fit fewer parameters, narrow "
                         "--bounds or give better configured values")
    best = min(converged, key=lambda r: r["cost"])
    tried = [{k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in r.items()
              if k != "z"} | {"best": r is best} for r in results]
    return np.asarray(best["z"], float), tried
