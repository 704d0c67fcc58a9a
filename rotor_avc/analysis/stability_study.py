"""Threshold-of-stability studies over configuration parameters (Werner 2017, Secs. 4.3-4.9).

A study starts from a machine config, applies named *variants* (the config's ``variants:``
section: dotted config paths -> values, e.g. Table 2's case d ``{foundation.kind: rigid}``) and
varies one or two parameters over a grid, running the threshold procedure of
:mod:`rotor_avc.analysis.stability_threshold` at every point (Figs. 7-11 are such maps).

A varied parameter is written ``PATHS=RANGE`` (command line ``--vary`` and the config's
``studies:`` section alike):

* ``PATHS``: one or more dotted config paths, comma-separated; all take the same value, e.g.
  ``foundation.stiffness_n_per_m.z,foundation.stiffness_n_per_m.y`` for an isotropic foundation.
  With ``*=`` instead of ``=`` the values are factors on each path's base value (Sec. 4.4: the
  foundation stiffness times 0.2 ... 5).
* ``RANGE``: ``START:STOP:N`` (linear), ``START:STOP:N:log`` or a list ``[v1, v2, ...]``.

The grid points run on the study engine (:mod:`rotor_avc.studies`): in this process, in local
processes or on a Dask cluster, with the same results.
"""
from __future__ import annotations

import importlib
import math
from dataclasses import dataclass

import numpy as np

from ..section import Section
from ..errors import ConfigError
from ..machine import MODELS, Machine, machine_from_section
from ..model_config.roller_bearing_rotor import StudySettings
from ..settings import ThresholdSettings, analysis_settings, read_settings
from ..studies.engine import StudySpec, run_study as run_points
from ..studies.overrides import with_overrides
from ..studies.points import Grid, Vary, parse_vary
from .sampled_loop import machine_sampled_loop
from .stability_threshold import ThresholdResult, stability_threshold

RAD_S_PER_RPM = math.pi / 30.0


# -- variants -----------------------------------------------------------------------------------
def with_variants(cfg: Section, names) -> Section:
    """The config with its named ``variants`` applied in the order given."""
    known = cfg.section("variants", {})
    for name in names:
        if not known.has(name):
            raise known.error(str(name), "no such variant",
                              fix="use one of: " + (", ".join(map(str, known.keys())) or "(none defined)"))
        cfg = with_overrides(cfg, known.section(name).data, f"variants.{name}")
    return cfg


# -- the threshold of one configuration ---------------------------------------------------------
def threshold_settings(cfg: Section) -> ThresholdSettings:
    """``analysis.stability`` of a config, validated."""
    return analysis_settings(cfg).stability


def whirl_start(cfg: Section, settings: ThresholdSettings) -> float:
    """First damping frequency of the iteration (rad/s): the number given, or for ``model`` the
    model module's ``whirl_start_rad_s(cfg)`` (Werner 2017: eq. 14)."""
    if settings.w_F_start != "model":
        return float(settings.w_F_start)
    model = cfg.string("model")
    estimate = getattr(importlib.import_module(MODELS[model]), "whirl_start_rad_s", None)
    if estimate is None:
        raise ConfigError("analysis.stability.w_F_start", f"model {model!r} has no estimate of "
                          "the whirl frequency", fix="give the start value in rad/s", source=cfg.source)
    return estimate(cfg)


def stability_loop(machine: Machine, settings: ThresholdSettings):
    """The loop the threshold is computed for: the continuous ``ClosedLoop``, or with
    ``controller: sampled`` the sampled loop of the digital controllers."""
    if settings.controller == "continuous" or not machine.controllers:
        return machine.loop
    return machine_sampled_loop(machine)


def machine_threshold(cfg: Section) -> tuple[Machine, ThresholdResult]:
    """Build the machine of a config and run the threshold procedure with its settings."""
    machine = machine_from_section(cfg)
    s = threshold_settings(cfg)
    result = stability_threshold(stability_loop(machine, s), whirl_start(cfg, s),
                                 s.speed_min_rpm * RAD_S_PER_RPM, s.speed_max_rpm * RAD_S_PER_RPM,
                                 n_grid=s.n_grid, rel_tol=s.rel_tol, max_iter=s.max_iter)
    return machine, result


def study_from_config(cfg: Section, name: str) -> tuple[Section, list[Vary]]:
    """The config of a named study (its variants applied) and its varied parameters."""
    studies = cfg.section("studies", {})
    if not studies.has(name):
        raise studies.error(name, "no such study",
                            fix="use one of: " + (", ".join(map(str, studies.keys())) or "(none defined)"))
    sec = studies.section(name)
    study = read_settings(StudySettings, sec)
    return (with_variants(cfg, study.variants),
            [parse_vary(v, f"{sec.path}.vary[{i}]") for i, v in enumerate(study.vary)])


# -- running a study ----------------------------------------------------------------------------
@dataclass(frozen=True)
class ThresholdPoint:
    """Study evaluator: the threshold summary and status of the config with a point's
    overrides (``status`` ``failed (...)`` for a point whose evaluation raised)."""

    cfg: Section
    field: str = "--vary"
    fields = {"threshold_rpm": float, "whirl_rad_s": float, "critical_mode": int, "status": str}

    def prepare(self) -> Section:
        return self.cfg

    def evaluate(self, cfg: Section, point) -> dict:
        result = machine_threshold(with_overrides(cfg, point.overrides, self.field))[1]
        return {**result.summary(), "status": result.status}

    def describe(self) -> dict:
        return {"threshold": self.cfg.data}


@dataclass
class StudyResult:
    """Thresholds over a 1-D or 2-D parameter grid: ``records[i]`` or ``records[i, j]`` (the
    threshold summary and status) for ``varies[0].values[i]`` (and ``varies[1].values[j]``)."""

    varies: list[Vary]
    records: np.ndarray             # object array of dicts

    def _field(self, key: str) -> np.ndarray:
        return np.vectorize(lambda r: np.nan if r[key] is None else r[key],
                            otypes=[float])(self.records)

    @property
    def threshold_rpm(self) -> np.ndarray:
        """Thresholds in rpm; NaN where none was found (see :attr:`status`)."""
        return self._field("threshold_rpm")

    @property
    def whirl_rad_s(self) -> np.ndarray:
        return self._field("whirl_rad_s")

    @property
    def status(self) -> np.ndarray:
        return np.vectorize(lambda r: r["status"], otypes=[object])(self.records)

    def rows(self) -> list[dict]:
        """One dict per grid point: the varied values, then the threshold summary and status."""
        out = []
        for idx in np.ndindex(self.records.shape):
            row = {v.label: float(v.values[i]) for v, i in zip(self.varies, idx)}
            row.update(self.records[idx])
            out.append(row)
        return out

    def maximum(self) -> dict | None:
        """The grid point with the highest threshold (None if no point has one)."""
        n = self.threshold_rpm
        if np.all(np.isnan(n)):
            return None
        return self.rows()[int(np.nanargmax(n))]


def run_study(cfg: Section, varies: list[Vary], field: str = "--vary", backend=None,
              batch_size: int | None = None, out=None, progress: bool = False) -> StudyResult:
    """Run the threshold procedure at every point of the grid spanned by one or two ``varies``
    on the study engine (``backend``, ``batch_size``, ``out``: the results folder, resumed;
    :func:`rotor_avc.studies.engine.run_study`)."""
    if not 1 <= len(varies) <= 2:
        raise ConfigError(field, f"a study varies one or two parameters (got {len(varies)})",
                          fix="give --vary once or twice (comma-join paths that move together)")
    grid = Grid(varies, cfg, field)
    run = run_points(StudySpec(grid, ThresholdPoint(cfg, field)), backend, out, batch_size,
                     progress)
    records = np.empty(grid.shape, dtype=object)
    for o in run.outcomes:
        records[np.unravel_index(o.index, grid.shape)] = o.record or {
            "threshold_rpm": None, "whirl_rad_s": None, "critical_mode": None,
            "status": f"failed ({o.error})"}
    return StudyResult(list(varies), records)
