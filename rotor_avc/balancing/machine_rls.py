"""RLS estimate of a machine's static and moment unbalance from its measured signals.

The generalisation of the Zhou & Shi 2001 regression to any LinearPlant, whose 1x responses are
linear in the unbalances (Werner 2021 eq. 42): with the influence coefficients ``A(Omega, Omega')``
of :mod:`.influence` each measured channel is, to the
quasi-steady 1x approximation, ``y_c = Re{(A_c,e (u_e + c_e) + A_c,a (u_a + c_a)) e^{j theta}}``,
where ``c`` are the balancer's known corrections. With the unknowns
``p = [Re u_e, Im u_e, Re u_a, Im u_a]`` each channel gives one regression row::

    y_c - Re{A_c . c e^{j theta}} = [Re(A_c,e e^{j theta}), -Im(A_c,e e^{j theta}),
                                     Re(A_c,a e^{j theta}), -Im(A_c,a e^{j theta})] . p

solved by :class:`.rls.RlsFilter` (all channels of a sample in one update). ``P0`` is the prior
``diag(prior_e^2, prior_e^2, prior_a^2, prior_a^2) / noise_std^2``. Below ``min_speed_rad_s``
(or outside the table) the response carries no usable information and the estimator holds, as it
does for NaN/Inf samples -- never extrapolating or diverging. The approximation ignores the
transient (sudden) vibration of a resonance passage; a slow run-up keeps it small.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .influence import InfluenceTable
from .plane import MachinePlane
from .rls import RlsFilter


@dataclass(frozen=True)
class MachineSample:
    """What the machine balancer reads at one instant: time, shaft angle, speed, angular
    acceleration, the channel values (in the table's channel order) and its actual position."""

    t: float
    angle: float
    speed: float
    accel: float
    signals: np.ndarray
    position: complex = 0j


class MachineImbalanceRls:
    """Estimator interface of :class:`.block.BalancerBlock` for a LinearPlant machine."""

    def __init__(self, table: InfluenceTable, plane: MachinePlane, prior_std_kg_m: float,
                 prior_std_kg_m2: float, noise_std: float, min_speed_rad_s: float,
                 forgetting: float = 1.0):
        for name, v in (("prior_std_kg_m", prior_std_kg_m), ("prior_std_kg_m2", prior_std_kg_m2),
                        ("noise_std", noise_std)):
            if not (math.isfinite(v) and v > 0):
                raise ModelError(f"{name} must be > 0 (got {v})")
        if not min_speed_rad_s > 0:
            raise ModelError(f"min_speed must be > 0 (got {min_speed_rad_s}): at zero speed an "
                             "unbalance produces no signal")
        self.table = table
        self.plane = plane
        self.min_speed_rad_s = float(min_speed_rad_s)
        prior = np.array([prior_std_kg_m] * 2 + [prior_std_kg_m2] * 2)
        self.filter = RlsFilter(4, (prior / noise_std) ** 2, forgetting)
        self.reset()

    def reset(self) -> None:
        self.filter.reset()
        self.n_held = 0

    def update(self, sample: MachineSample) -> bool:
        if np.shape(sample.signals) != (len(self.table.channels),):
            raise ModelError(f"the balancer expects {len(self.table.channels)} signals "
                             f"({', '.join(self.table.channels)}), got shape "
                             f"{np.shape(sample.signals)}")
        ok = (math.isfinite(sample.speed) and math.isfinite(sample.angle)
              and math.isfinite(sample.accel) and sample.speed >= self.min_speed_rad_s
              and self.table.covers(sample.speed))
        if ok:
            A = self.table.at(sample.speed, sample.accel)             # (C, 2)
            rot = A * complex(math.cos(sample.angle), math.sin(sample.angle))
            corr = self.plane.corrections(sample.position)
            known = (rot @ np.array([corr["static"], corr["moment"]])).real
            X = np.column_stack([rot[:, 0].real, -rot[:, 0].imag, rot[:, 1].real, -rot[:, 1].imag])
            ok = self.filter.update(X, np.asarray(sample.signals, dtype=float) - known)
        if not ok:
            self.n_held += 1
        return ok

    def amplitudes(self) -> dict[str, complex]:
        p = self.filter.theta
        return {"static": complex(p[0], p[1]), "moment": complex(p[2], p[3])}

    def std(self) -> dict[str, float]:
        if not self.filter.n_updates:
            return {"static": math.inf, "moment": math.inf}
        cov = self.filter.covariance
        return {"static": math.sqrt(max(cov[0, 0] + cov[1, 1], 0.0)),
                "moment": math.sqrt(max(cov[2, 2] + cov[3, 3], 0.0))}
