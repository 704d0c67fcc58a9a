"""Threshold-of-stability studies over configuration parameters (seed 003, Secs. 4.3-4.9).

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
"""
from __future__ import annotations

import copy
import importlib
import math
from dataclasses import dataclass

import numpy as np
import yaml

from ..config import Section
from ..errors import ConfigError
from ..machine import MODELS, Machine, machine_from_section
from ..settings import ThresholdSettings, analysis_settings
from .sampled_loop import machine_sampled_loop
from .stability_threshold import ThresholdResult, stability_threshold

RAD_S_PER_RPM = math.pi / 30.0


# -- variants and overrides ---------------------------------------------------------------------
def set_path(data: dict, path: str, value, field: str) -> None:
    """Set ``data[a][b][c] = value`` for ``path = "a.b.c"``; every parent must exist."""
    keys = path.split(".")
    node = data
    for depth, key in enumerate(keys[:-1]):
        if not isinstance(node, dict) or key not in node or not isinstance(node[key], dict):
            raise ConfigError(field, f"{path!r}: the config has no section "
                                     f"{'.'.join(keys[:depth + 1])!r}",
                              fix="give a dotted path of the config file, e.g. "
                                  "foundation.stiffness_n_per_m.z")
        node = node[key]
    if not keys[-1]:
        raise ConfigError(field, f"{path!r} is not a dotted config path", fix="remove the stray dot")
    node[keys[-1]] = copy.deepcopy(value)


def get_path(data: dict, path: str, field: str):
    node = data
    for key in path.split("."):
        if not isinstance(node, dict) or key not in node:
            raise ConfigError(field, f"the config has no value at {path!r}",
                              fix="give the dotted path of an existing value (a factor `*=` needs one)")
        node = node[key]
    return node


def with_overrides(cfg: Section, overrides: dict, field: str) -> Section:
    """A copy of the config with dotted-path overrides applied in order."""
    data = copy.deepcopy(cfg.data)
    for path, value in overrides.items():
        set_path(data, str(path), value, field)
    return Section(data, "", cfg.source)


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
    """``analysis.stability`` of a config, validated (defaults: digest 5)."""
    return analysis_settings(cfg).stability


def whirl_start(cfg: Section, settings: ThresholdSettings) -> float:
    """First damping frequency of the iteration (rad/s): the number given, or for ``model`` the
    model module's ``whirl_start_rad_s(cfg)`` (seed 003: eq. 14)."""
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


# -- varied parameters --------------------------------------------------------------------------
@dataclass(frozen=True)
class Vary:
    """One axis of a study: config paths that move together over ``values``."""

    paths: tuple[str, ...]
    values: np.ndarray
    scale: bool = False

    @property
    def label(self) -> str:
        return ",".join(self.paths) + (" (factor)" if self.scale else "")

    def overrides(self, cfg: Section, value: float, field: str) -> dict:
        if not self.scale:
            return {p: float(value) for p in self.paths}
        out = {}
        for p in self.paths:
            base = get_path(cfg.data, p, field)
            if isinstance(base, bool) or not isinstance(base, (int, float)):
                raise ConfigError(field, f"{p!r} is not a number and cannot be scaled",
                                  fix="use `=` with values instead of `*=`")
            out[p] = float(base) * float(value)
        return out


def parse_vary(text: str, field: str = "--vary") -> Vary:
    """``PATHS=RANGE`` or ``PATHS*=RANGE`` (see the module docstring) -> :class:`Vary`."""
    fix = ("write PATH[,PATH...]=START:STOP:N[:log] or PATH*=... or PATH=[v1, v2, ...], e.g. "
           "foundation.stiffness_n_per_m.z=2.0e+7:7.5e+8:25")
    if "=" not in text:
        raise ConfigError(field, f"{text!r} has no `=`", fix=fix)
    lhs, rhs = text.split("=", 1)
    scale = lhs.endswith("*")
    paths = tuple(p.strip() for p in lhs.rstrip("*").split(","))
    if not all(paths):
        raise ConfigError(field, f"{text!r}: empty config path", fix=fix)
    rhs = rhs.strip()
    if rhs.startswith("["):
        try:
            values = yaml.safe_load(rhs)
            values = np.array([float(v) for v in values])
        except (yaml.YAMLError, TypeError, ValueError):
            raise ConfigError(field, f"{rhs!r} is not a list of numbers", fix=fix) from None
    else:
        parts = rhs.split(":")
        try:
            if len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] != "log"):
                raise ValueError
            start, stop, n = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise ConfigError(field, f"{rhs!r} is not START:STOP:N[:log]", fix=fix) from None
        if n < 1 or not (math.isfinite(start) and math.isfinite(stop)):
            raise ConfigError(field, f"{rhs!r}: need finite START, STOP and N >= 1", fix=fix)
        if len(parts) == 4:
            if start <= 0 or stop <= 0:
                raise ConfigError(field, f"{rhs!r}: a log range needs START, STOP > 0", fix=fix)
            values = np.geomspace(start, stop, n)
        else:
            values = np.linspace(start, stop, n)
    if values.size == 0 or not np.all(np.isfinite(values)):
        raise ConfigError(field, f"{text!r} gives no finite values", fix=fix)
    return Vary(paths, values, scale)


def study_from_config(cfg: Section, name: str) -> tuple[Section, list[Vary]]:
    """The config of a named study (its variants applied) and its varied parameters."""
    studies = cfg.section("studies", {})
    if not studies.has(name):
        raise studies.error(name, "no such study",
                            fix="use one of: " + (", ".join(map(str, studies.keys())) or "(none defined)"))
    sec = studies.section(name)
    sec.check_keys(("variants", "vary"))
    variants = sec.raw("variants", [])
    if not isinstance(variants, list):
        raise sec.error("variants", "must be a list of variant names",
                        fix="write [d] or [demo, velocity_feedback]")
    vary = sec.raw("vary")
    if not isinstance(vary, list) or not 1 <= len(vary) <= 2 or not all(isinstance(v, str) for v in vary):
        raise sec.error("vary", "must be a list of one or two `PATHS=RANGE` strings",
                        fix='write ["bearings.stiffness_n_per_m.z=1.0e+8:3.0e+8:21"]')
    return (with_variants(cfg, variants),
            [parse_vary(v, f"{sec.path}.vary[{i}]") for i, v in enumerate(vary)])


# -- running a study ----------------------------------------------------------------------------
@dataclass
class StudyResult:
    """Thresholds over a 1-D or 2-D parameter grid: ``results[i]`` or ``results[i, j]`` for
    ``varies[0].values[i]`` (and ``varies[1].values[j]``)."""

    varies: list[Vary]
    results: np.ndarray             # object array of ThresholdResult

    def _field(self, fn) -> np.ndarray:
        return np.vectorize(fn, otypes=[float])(self.results)

    @property
    def threshold_rpm(self) -> np.ndarray:
        """Thresholds in rpm; NaN where none was found (see :attr:`status`)."""
        return self._field(lambda r: np.nan if r.summary()["threshold_rpm"] is None
                           else r.threshold_rpm)

    @property
    def whirl_rad_s(self) -> np.ndarray:
        return self._field(lambda r: np.nan if r.summary()["whirl_rad_s"] is None else r.whirl_rad_s)

    @property
    def status(self) -> np.ndarray:
        return np.vectorize(lambda r: r.status, otypes=[object])(self.results)

    def rows(self) -> list[dict]:
        """One dict per grid point: the varied values, then the threshold summary and status."""
        out = []
        for idx in np.ndindex(self.results.shape):
            r = self.results[idx]
            row = {v.label: float(v.values[i]) for v, i in zip(self.varies, idx)}
            row.update(r.summary())
            row["status"] = r.status
            out.append(row)
        return out

    def maximum(self) -> dict | None:
        """The grid point with the highest threshold (None if no point has one)."""
        n = self.threshold_rpm
        if np.all(np.isnan(n)):
            return None
        return self.rows()[int(np.nanargmax(n))]


def run_study(cfg: Section, varies: list[Vary], field: str = "--vary") -> StudyResult:
    """Run the threshold procedure at every point of the grid spanned by one or two ``varies``."""
    if not 1 <= len(varies) <= 2:
        raise ConfigError(field, f"a study varies one or two parameters (got {len(varies)})",
                          fix="give --vary once or twice (comma-join paths that move together)")
    shape = tuple(len(v.values) for v in varies)
    results = np.empty(shape, dtype=object)
    for idx in np.ndindex(shape):
        overrides = {}
        for v, i in zip(varies, idx):
            overrides.update(v.overrides(cfg, v.values[i], field))
        results[idx] = machine_threshold(with_overrides(cfg, overrides, field))[1]
    return StudyResult(list(varies), results)
