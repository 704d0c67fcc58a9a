"""Monte-Carlo robustness of a machine and its controllers under parameter uncertainty.

Each point is the config with sampled parameters (:class:`~rotor_avc.studies.points.Sample`);
its record holds

* the closed-loop poles at every speed of ``analysis.pole_speeds_hz`` with the damping
  procedure of the config (``analysis.pole_method``, :func:`rotor_avc.analysis.poles.machine_poles`):
  ``max_real_1_per_s`` = max Re(s) over those speeds, ``stable`` <=> max Re(s) < 0, the
  stability margin ``stability_margin_1_per_s`` = -max Re(s) (the decay rate of the least
  damped mode) and the smallest damping ratio;
* the peak over speed of each chosen response's unbalance FRF (default: the bearing responses)
  and the speed of that peak (:func:`rotor_avc.closed_loop.frf.unbalance_frf`).

:func:`summarize` turns the records into the stability probability (with its 95 % Wilson
interval) and quantiles of every number.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from ..closed_loop.frf import unbalance_frf
from ..section import Section
from ..errors import ConfigError
from ..machine import machine_from_section
from ..studies.overrides import with_overrides
from .poles import machine_poles

QUANTILES = (0.05, 0.5, 0.95)


@dataclass(frozen=True)
class RobustnessPoint:
    """Study evaluator: stability and peak responses of the config with a point's overrides."""

    cfg: Section
    speed_hz: tuple[float, ...]
    pole_speeds_hz: tuple[float, ...]
    responses: tuple[str, ...]
    units: tuple[str, ...]          # of each response (SI per unit excitation)

    @property
    def fields(self) -> dict:
        out = {"stable": bool, "max_real_1_per_s": float, "stability_margin_1_per_s": float,
               "min_damping_ratio": float}
        for name in self.responses:
            out[f"peak_{name}"] = float
            out[f"peak_speed_hz_{name}"] = float
        return out

    def prepare(self) -> np.ndarray:
        return 2 * np.pi * np.asarray(self.speed_hz)

    def evaluate(self, speeds_rad_s: np.ndarray, point) -> dict:
        machine = machine_from_section(with_overrides(self.cfg, point.overrides, "--sample"))
        poles = np.concatenate([machine_poles(machine, 2 * math.pi * f).poles
                                for f in self.pole_speeds_hz])
        max_real = float(np.max(poles.real))
        mag = np.abs(poles)
        record = {"stable": max_real < 0.0, "max_real_1_per_s": max_real,
                  "stability_margin_1_per_s": -max_real,
                  "min_damping_ratio": float(np.min(-poles.real[mag > 0] / mag[mag > 0]))}
        frf = unbalance_frf(machine.loop, speeds_rad_s)
        for name in self.responses:
            amplitude = np.abs(frf.responses[name])
            k = int(np.argmax(amplitude))
            record[f"peak_{name}"] = float(amplitude[k])
            record[f"peak_speed_hz_{name}"] = float(self.speed_hz[k])
        return record

    def describe(self) -> dict:
        return {"robustness": self.cfg.data, "speed_hz": self.speed_hz,
                "pole_speeds_hz": self.pole_speeds_hz, "responses": self.responses}

    def unit_of(self, field: str) -> str:
        """SI unit of a record field."""
        for name, unit in zip(self.responses, self.units):
            if field == f"peak_{name}":
                return unit
        return {"min_damping_ratio": "1", "stable": ""}.get(
            field, "Hz" if field.startswith("peak_speed_hz_") else "1/s")


def robustness_point(cfg: Section, speed_hz=None, responses=None) -> RobustnessPoint:
    """The evaluator for a config: speeds from ``speed_hz`` or ``analysis.frf_speed_hz``, poles
    at ``analysis.pole_speeds_hz`` (default 0), responses ``responses`` or every bearing
    response. Builds the base machine once to check all of it."""
    machine = machine_from_section(cfg)
    if speed_hz is None:
        rng = machine.analysis.frf_speed_hz
        if rng is None:
            raise ConfigError("--speed-hz", "no speeds given and the config has no "
                              "analysis.frf_speed_hz", fix="give --speed-hz 1:250:2000")
        speed_hz = np.linspace(rng.start, rng.stop, rng.n)
    units = unbalance_frf(machine.loop, [2 * np.pi * speed_hz[0]]).units
    names = list(units)
    chosen = responses or [n for n in names if n.startswith("bearing")]
    unknown = [n for n in chosen if n not in names]
    if unknown or not chosen:
        raise ConfigError("--response", f"no response {unknown[0] if unknown else '(none)'!r}",
                          fix="choose from: " + ", ".join(names))
    poles = machine.analysis.pole_speeds_hz
    return RobustnessPoint(cfg, tuple(float(f) for f in speed_hz), tuple(float(f) for f in poles),
                           tuple(chosen), tuple(units[n] for n in chosen))


def wilson_interval(k: int, n: int, z: float = NormalDist().inv_cdf(0.975)) -> tuple[float, float]:
    """95 % Wilson score interval of a binomial proportion ``k / n``."""
    if n == 0:
        return math.nan, math.nan
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def summarize(records: list[dict], n_failed: int) -> dict:
    """Stability probability (with its Wilson interval) over the evaluated points, and per
    number of the records: mean, std, min, 5/50/95 % quantiles, max."""
    stable = sum(bool(r["stable"]) for r in records)
    lo, hi = wilson_interval(stable, len(records))
    out = {"points": len(records), "failed": n_failed, "stable": stable,
           "stability_probability": stable / len(records) if records else math.nan,
           "probability_95_low": lo, "probability_95_high": hi, "metrics": {}}
    for name in (records[0] if records else {}):
        if name == "stable":
            continue
        v = np.array([r[name] for r in records], dtype=float)
        q = np.quantile(v, QUANTILES)
        out["metrics"][name] = {"mean": float(v.mean()), "std": float(v.std(ddof=1)) if v.size > 1
                                else 0.0, "min": float(v.min()), "p5": float(q[0]),
                                "p50": float(q[1]), "p95": float(q[2]), "max": float(v.max())}
    return out
