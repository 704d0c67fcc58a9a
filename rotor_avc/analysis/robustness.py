"""Monte-Carlo robustness of a machine and its controllers under parameter uncertainty.

Each point is the config with sampled parameters (:class:`~rotor_avc.studies.points.Sample`);
its record holds

* the closed-loop poles at every speed of ``analysis.pole_speeds_hz`` with the damping
  procedure of the config (``analysis.pole_method``, :func:`rotor_avc.analysis.poles.machine_poles`):
  ``max_real_1_per_s`` = max Re(s) over those speeds, ``stable`` <=> max Re(s) < 0, the
  stability margin ``stability_margin_1_per_s`` = -max Re(s) (the decay rate of the least
  damped mode) and the smallest damping ratio;
* the resonance peak of each chosen response's unbalance FRF over speed (default: the bearing
  responses; :func:`rotor_avc.closed_loop.frf.unbalance_frf`) and its speed: the largest
  interior local maximum, lower neighbours on both sides (:func:`resonance_peak`; none: empty);
  a maximum over the grid at its first or last speed, the response rising towards it, is no
  resonance peak but ``grid_end_max_<response>`` = ``low`` / ``high``: the resonance lies
  beyond the speed range, which should be extended.

:func:`summarize` turns the records into the stability probability (with its 95 % Wilson
interval), quantiles of every number (over the points that have it) and, per response, how
many points have their maximum at a grid end.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np
import scipy.signal

from ..closed_loop.frf import unbalance_frf
from ..section import Section
from ..errors import ConfigError
from ..machine import machine_from_section
from ..studies.overrides import with_overrides
from .poles import machine_poles

QUANTILES = (0.05, 0.5, 0.95)
GRID_END = "grid_end_max_"
EXTEND = "at the grid end (rising): extend the speed range"


def resonance_peak(speed_hz, amplitude) -> tuple[float | None, float | None, str | None]:
    """``(peak, speed_hz, grid_end)``: the largest interior local maximum of ``amplitude``
    (neighbours lower on both sides, a plateau at its middle: ``scipy.signal.find_peaks``) or
    ``None, None`` without one, and ``"low"`` / ``"high"`` when the maximum over the whole grid
    lies at its first / last speed (else ``None``)."""
    amp = np.asarray(amplitude, dtype=float)
    interior, _ = scipy.signal.find_peaks(amp)
    k = int(np.argmax(amp))
    end = "low" if k == 0 else "high" if k == amp.size - 1 else None
    if interior.size == 0:
        return None, None, end
    i = int(interior[np.argmax(amp[interior])])
    return float(amp[i]), float(speed_hz[i]), end


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
            out[GRID_END + name] = str
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
            (record[f"peak_{name}"], record[f"peak_speed_hz_{name}"],
             record[GRID_END + name]) = resonance_peak(self.speed_hz, np.abs(frf.responses[name]))
        return record

    def describe(self) -> dict:
        return {"robustness": self.cfg.data, "speed_hz": self.speed_hz,
                "pole_speeds_hz": self.pole_speeds_hz, "responses": self.responses}

    def unit_of(self, field: str) -> str:
        """SI unit of a record field."""
        for name, unit in zip(self.responses, self.units):
            if field == f"peak_{name}":
                return unit
        if field.startswith(GRID_END):
            return ""
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
    """Stability probability (with its Wilson interval) over the evaluated points; per number of
    the records, over the points that have it (``n``): mean, std, min, 5/50/95 % quantiles, max;
    per response whose maximum lies at a grid end in some points: how many, at which end."""
    stable = sum(bool(r["stable"]) for r in records)
    lo, hi = wilson_interval(stable, len(records))
    out = {"points": len(records), "failed": n_failed, "stable": stable,
           "stability_probability": stable / len(records) if records else math.nan,
           "probability_95_low": lo, "probability_95_high": hi, "metrics": {}, "grid_end": {}}
    for name in (records[0] if records else {}):
        if name.startswith(GRID_END):
            ends = [r[name] for r in records if r[name] is not None]
            if ends:
                out["grid_end"][name[len(GRID_END):]] = {
                    "points": len(ends), "low": ends.count("low"), "high": ends.count("high"),
                    "note": f"maximum {EXTEND}"}
            continue
        v = np.array([r[name] for r in records if r[name] is not None], dtype=float)
        if name == "stable" or v.size == 0:
            continue
        q = np.quantile(v, QUANTILES)
        out["metrics"][name] = {"n": int(v.size), "mean": float(v.mean()),
                                "std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
                                "min": float(v.min()), "p5": float(q[0]), "p50": float(q[1]),
                                "p95": float(q[2]), "max": float(v.max())}
    return out


def grid_end_lines(summary: dict) -> list[str]:
    """One line per response with points whose maximum lies at a grid end."""
    return [f"{name}: maximum {EXTEND} ({g['points']} of {summary['points']} points; low end "
            f"{g['low']}, high end {g['high']}); the peak statistics are over interior peaks"
            for name, g in summary["grid_end"].items()]
