"""Online identification of the influence matrix by recursive least squares (complex).

Between two updates the applied actuator phasors change by ``dA`` and the measured error
phasors by ``dE``; quasi-steadily ``dE = G dA`` (the disturbance cancels in the difference
while the speed holds). With a prior ``G0`` (the speed schedule at the current speed) the
estimator learns the correction ``D = G - G0`` from ``y = dE - G0 dA = D dA``; the regressor is
normalised (``phi = dA / |dA|``, ``y / |dA|``), so the covariance is dimensionless.
The quasi-steady relation fails while the plant still rings from earlier changes; the small
changes of a converging loop are mostly such transients, so only changes above a fraction
``min_rel_change`` of the applied phasors are learnt from (measured on Werner 2021 at a resonance:
without it the estimate drifts and the loop stalls near -15 dB). RLS with forgetting ``lambda``
and one covariance shared by all sensor rows (Ljung, *System Identification*, 11.2): the
regression ``y^T = phi^T D^T`` run by the balancer's filter
(:class:`rotor_avc.balancing.rls.RlsFilter`, complex, ``D^T`` its (N, M) parameter, Joseph-form
covariance update)::

    eps = y - D phi,     k = P phi^* / (lambda + phi^T P phi^*),
    D^T <- D^T + k eps^T,   P  <- (I - k phi^T) P (I - k phi^T)^H / lambda + k k^H

Changes smaller than ``min_change`` are not used (no
covariance wind-up without excitation). ``residual`` is the a-priori prediction error relative
to ``|y|``: near 0 when the estimate predicts the change, >= 1 when it does not (a poor estimate).
"""
from __future__ import annotations

import numpy as np

from ..balancing.rls import RlsFilter
from ..errors import ModelError

#: initial covariance of the normalised regression: the first change outweighs the prior
INITIAL_COVARIANCE = 100.0


class InfluenceRls:
    """The correction ``D`` (M, N) of the scheduled influence matrix (module docstring)."""

    def __init__(self, n_sensors: int, n_actuators: int, forgetting: float, min_change: float,
                 min_rel_change: float = 0.1):
        if not 0 < forgetting <= 1:
            raise ModelError(f"the forgetting factor must lie in (0, 1] (got {forgetting})")
        if not min_change > 0:
            raise ModelError(f"the minimum change must be > 0 (got {min_change})")
        self.shape = (n_sensors, n_actuators)
        self.forgetting = float(forgetting)
        if not 0 <= min_rel_change < 1:
            raise ModelError("the minimum relative change must lie in [0, 1) "
                             f"(got {min_rel_change})")
        self.min_change = float(min_change)
        self.min_rel_change = float(min_rel_change)
        self.reset()

    def reset(self) -> None:
        m, n = self.shape
        self.filter = RlsFilter(n, INITIAL_COVARIANCE, self.forgetting,
                                theta0=np.zeros((n, m), complex))
        self.residual = 0.0

    @property
    def correction(self) -> np.ndarray:
        """``D`` (M, N)."""
        return self.filter.theta.T

    @correction.setter
    def correction(self, value: np.ndarray) -> None:
        self.filter.theta = np.asarray(value, complex).T.copy()

    @property
    def covariance(self) -> np.ndarray:
        return self.filter.P

    @covariance.setter
    def covariance(self, value: np.ndarray) -> None:
        self.filter.P = np.asarray(value, complex).copy()

    @property
    def n_updates(self) -> int:
        return self.filter.n_updates

    @n_updates.setter
    def n_updates(self, value: int) -> None:
        self.filter.n_updates = int(value)

    def update(self, d_applied: np.ndarray, d_error: np.ndarray, prior: np.ndarray,
               applied_norm: float = 0.0) -> bool:
        """One regression step from the changes ``dA`` (N,) and ``dE`` (M,); False if ``dA``
        is too small to learn from (below ``min_change`` or ``min_rel_change`` times the
        applied phasors' norm ``applied_norm``)."""
        scale = float(np.linalg.norm(d_applied))
        if not scale > max(self.min_change, self.min_rel_change * applied_norm):
            return False
        phi = d_applied / scale
        y = (d_error - prior @ d_applied) / scale
        eps = y - self.correction @ phi
        self.residual = float(np.linalg.norm(eps) / max(np.linalg.norm(d_error) / scale, 1e-300))
        return self.filter.update(phi[None, :], y[None, :])
