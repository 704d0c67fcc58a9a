"""``calibration.json``: the parameters with their intervals and identifiability, the
correlation matrix, the residual before and after, per recording the before/after measures
(rotor_avc.calibration.assessment) and the compare verdicts, the validation on held-out
recordings, and how the fit went."""
from __future__ import annotations

import math

import numpy as np

from .session import Calibration


def _finite(value):
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def parameter_rows(cal: Calibration) -> list[dict]:
    fit = cal.fit
    rows = []
    for j, p in enumerate(cal.params):
        rows.append({
            "path": p.label, "unit": p.unit, "initial": p.initial,
            "value": float(fit.values[j]) if fit.fitted[j] else None, "std": fit.std[j],
            "ci95": fit.ci95[j], "identifiable": fit.identifiable[j], "fitted": fit.fitted[j],
            "reason": fit.reasons[j],
            "bounds": [p.lower, p.upper],
            "prior": None if p.prior is None else {"mean": p.prior[0], "std": p.prior[1]},
            "sensitivity": _finite(fit.sensitivity[j])})
    return rows


def calibration_document(cal: Calibration) -> dict:
    fit = cal.fit
    labels = [p.label for p in cal.params]
    corr = [[_finite(v) for v in row] for row in np.asarray(fit.correlation)]
    return {
        "parameters": parameter_rows(cal),
        "correlation": {"parameters": labels, "matrix": corr},
        "residual": {"before": fit.chi2_before, "after": fit.chi2_after, "dof": fit.dof,
                     "measure": "reduced chi-square of the weighted residual",
                     "sensor_uncertainty": cal.floor, "point_uncertainty": cal.point},
        "validation": cal.validation,
        "data": cal.fitted,
        "left_out": cal.left_out,
        "fit": {"evaluations": fit.evaluations, "elapsed_s": fit.elapsed_s,
                "condition_number": _finite(fit.condition), "starts": fit.starts,
                "config": str(cal.config_path)},
    }
