"""The calibration problem: configured machine, fitted parameters, measured targets, and the
weighted residual of a parameter vector; with the study-engine evaluators of its Jacobian
columns and of a fit from one start.

The residual stacks, over every recording and used point, ``Re`` and ``Im`` of
``(y - (1 + g_c) m) / u`` (``y`` measured, ``m`` the model, ``u`` the point's uncertainty,
rotor_avc.calibration.targets), then ``g_c / floor`` per channel, then one term
``(value - mean) / std`` per Gaussian prior. ``g_c`` is the complex calibration error of channel
``c`` (one sensor of one recording: its 1x and H1 points share it) with the Gaussian prior of
standard deviation ``floor`` (``--sensor-uncertainty``: a sensor's calibration
uncertainty, magnitude and phase). It enters linearly, so it is eliminated in closed form for every parameter vector
(variable projection, Golub & Pereyra 1973)::

    g_c = sum_k (y_k - m_k) m_k^* / u_k^2  /  (sum_k |m_k|^2 / u_k^2 + 1 / floor^2)

and the Jacobian of this residual in the machine's parameters, and the covariance from it, are
those of the parameters with the gains marginalised: a parameter whose only effect is a uniform
change of a channel's level (a 10 kg foundation mass under a 9 t machine) carries no information
beyond a sensor's calibration. The residual is a pure function of the parameter values: the same
values give the same bits in any process, so a Jacobian computed on local processes or a Dask
cluster equals the serial one.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..machine import machine_from_config
from ..studies.points import Point
from .parameters import Parameter, applied
from .targets import DEFAULT_POINT_UNCERTAINTY, Target

#: default relative calibration uncertainty of a sensor channel (ISO 16063-21 back-to-back
#: calibration of an accelerometer: about 1 %)
DEFAULT_SENSOR_UNCERTAINTY = 0.01


@dataclass
class Problem:
    """What is fitted (``params``) to what (``targets``), starting from the configuration
    ``data`` (merged, of ``source``); ``floor`` the channels' calibration uncertainty (relative;
    0: the sensors are exact), ``point`` the points' relative uncertainty
    (rotor_avc.calibration.targets)."""

    data: dict
    source: str
    params: list[Parameter]
    targets: list[Target]
    floor: float = DEFAULT_SENSOR_UNCERTAINTY
    point: float = DEFAULT_POINT_UNCERTAINTY

    def __post_init__(self):
        pairs = [t.measured_vector(self.point) for t in self.targets]
        self.measured = np.concatenate([p[0] for p in pairs])
        self.uncertainty = np.concatenate([p[1] for p in pairs])
        if np.any(self.uncertainty <= 0):
            raise ModelError("a measured point is zero with no uncertainty: nothing to weigh "
                             "it by")
        keys = [(t.name, ch) for t in self.targets for ch in t.point_channels()]
        self.channels = list(dict.fromkeys(keys))
        index = {key: i for i, key in enumerate(self.channels)}
        self.channel_of = np.array([index[k] for k in keys], dtype=int)
        self.reference = np.array([p.reference for p in self.params])

    @property
    def points(self) -> int:
        """Complex measured points."""
        return int(self.measured.size)

    @property
    def initial(self) -> np.ndarray:
        return np.array([p.initial for p in self.params])

    def config(self, values) -> dict:
        return applied(self.data, self.params, values)

    def machine(self, values):
        return machine_from_config(self.config(values), f"{self.source} (calibrated values)")

    def model(self, values) -> np.ndarray:
        machine = self.machine(values)
        return np.concatenate([t.predicted(machine) for t in self.targets])

    def gains(self, model: np.ndarray) -> np.ndarray:
        """The channels' calibration errors ``g_c`` that fit ``model`` best (module docstring)."""
        n = len(self.channels)
        if self.floor == 0:
            return np.zeros(n, complex)
        w = 1.0 / self.uncertainty ** 2
        cross = (self.measured - model) * np.conj(model) * w
        num = (np.bincount(self.channel_of, cross.real, n)
               + 1j * np.bincount(self.channel_of, cross.imag, n))
        den = np.bincount(self.channel_of, np.abs(model) ** 2 * w, n) + 1.0 / self.floor ** 2
        return num / den

    def residual(self, values) -> np.ndarray:
        """Weighted residual of the physical parameter ``values`` (module docstring)."""
        m = self.model(values)
        g = self.gains(m)
        r = (self.measured - (1 + g[self.channel_of]) * m) / self.uncertainty
        prior = [(v - p.prior[0]) / p.prior[1] for p, v in zip(self.params, values)
                 if p.prior is not None]
        rg = g / self.floor if self.floor > 0 else np.zeros(0, complex)
        return np.concatenate([r.real, r.imag, rg.real, rg.imag, np.asarray(prior, float)])

    def scaled_residual(self, z) -> np.ndarray:
        """The residual of the normalised values ``z = value / reference``."""
        return self.residual(np.asarray(z) * self.reference)


@dataclass(frozen=True)
class Columns:
    """Point set of one Jacobian: point ``k`` is ``z`` with ``z_j + steps_j``, ``j`` the
    ``k``-th of ``columns``."""

    z: tuple
    steps: tuple
    columns: tuple

    def __len__(self) -> int:
        return len(self.columns)

    def point(self, index: int) -> Point:
        z = list(self.z)
        z[self.columns[index]] += self.steps[self.columns[index]]
        return Point(int(index), {"z": z}, {})

    def describe(self) -> dict:
        return {"z": list(self.z), "steps": list(self.steps), "columns": list(self.columns)}


@dataclass(frozen=True)
class Starts:
    """Point set of a multi-start fit: point ``k`` starts at ``starts[k]`` (normalised)."""

    starts: tuple

    def __len__(self) -> int:
        return len(self.starts)

    def point(self, index: int) -> Point:
        return Point(int(index), {"z": list(self.starts[index])}, {})

    def describe(self) -> dict:
        return {"starts": [list(s) for s in self.starts]}


class ResidualEvaluator:
    """Evaluator of the study engine: the scaled residual at a point's ``z``."""

    fields = None

    def __init__(self, problem: Problem):
        self.problem = problem

    def prepare(self):
        return None

    def evaluate(self, context, point: Point) -> dict:
        return {"residual": self.problem.scaled_residual(point.values["z"])}

    def describe(self) -> dict:
        return {"calibration": [p.label for p in self.problem.params]}


class FitEvaluator(ResidualEvaluator):
    """Evaluator of the study engine: a whole fit from a point's start (serial Jacobians), for
    multi-starts; ``fit`` is :func:`rotor_avc.calibration.fit.local_fit`."""

    def __init__(self, problem: Problem, fit, free: tuple, bounds):
        super().__init__(problem)
        self.fit, self.free, self.bounds = fit, free, bounds

    def evaluate(self, context, point: Point) -> dict:
        result = self.fit(self.problem, np.array(point.values["z"]), self.free, self.bounds)
        return {"z": result.x, "cost": float(result.cost), "status": int(result.status),
                "nfev": int(result.nfev)}
