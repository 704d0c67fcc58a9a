"""The parameter points of a study: a grid over config paths, or a seeded random sample.

An axis names one or more dotted config paths that take the same value (comma-separated, e.g.
``foundation.stiffness_n_per_m.z,foundation.stiffness_n_per_m.y``); with ``*=`` instead of
``=`` the values are factors on each path's base value.

* **grid axis** ``PATHS=RANGE`` (:func:`parse_vary`): ``START:STOP:N`` (linear),
  ``START:STOP:N:log`` or a list ``[v1, v2, ...]``; one or more axes span a grid whose points
  are numbered in C order (the last axis fastest, as ``numpy.ndindex``);
* **sample axis** ``PATHS=DIST`` (:func:`parse_sample`): ``normal(MEAN, STD)``,
  ``uniform(LOW, HIGH)`` or ``lognormal(MU, SIGMA)`` (``ln x ~ N(MU, SIGMA)``: median
  ``e^MU``; ``*=lognormal(0, 0.1)`` is a factor of median 1 and about +-10 %).

Point ``i`` of a sample is drawn from its own generator, ``SeedSequence(seed, spawn_key=(i,))``
(child ``i`` of the study seed), one value per axis in axis order: a point's values depend on
the study seed and its index only, never on which worker draws it or when.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..section import Section
from ..errors import ConfigError
from ..resources import check_memory
from .overrides import get_path, with_overrides


@dataclass(frozen=True)
class Point:
    """Point ``index`` of a study: the axis values by label, and the config overrides."""

    index: int
    values: dict
    overrides: dict


class ConfigAxis:
    """Mixin of an axis's config ``paths`` (moving together) and ``scale`` (the values are
    factors on the base values)."""

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


def _split_axis(text: str, field: str, fix: str) -> tuple[tuple[str, ...], bool, str]:
    if "=" not in text:
        raise ConfigError(field, f"{text!r} has no `=`", fix=fix)
    lhs, rhs = text.split("=", 1)
    paths = tuple(p.strip() for p in lhs.rstrip("*").split(","))
    if not all(paths):
        raise ConfigError(field, f"{text!r}: empty config path", fix=fix)
    return paths, lhs.endswith("*"), rhs.strip()


# -- grids ----------------------------------------------------------------------------------------
#: memory planned per point of a study (its outcome record and bookkeeping)
OUTCOME_BYTES = 4096


@dataclass(frozen=True)
class Vary(ConfigAxis):
    """One axis of a grid: config paths that move together over ``values``."""

    paths: tuple[str, ...]
    values: np.ndarray
    scale: bool = False


def parse_vary(text: str, field: str = "--vary") -> Vary:
    """``PATHS=RANGE`` or ``PATHS*=RANGE`` (see the module docstring) -> :class:`Vary`."""
    fix = ("write PATH[,PATH...]=START:STOP:N[:log] or PATH*=... or PATH=[v1, v2, ...], e.g. "
           "foundation.stiffness_n_per_m.z=2.0e+7:7.5e+8:25")
    paths, scale, rhs = _split_axis(text, field, fix)
    if rhs.startswith("["):
        try:
            if not rhs.endswith("]"):
                raise ValueError
            values = np.array([float(v) for v in rhs[1:-1].split(",")])
        except ValueError:
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
        check_memory(n * OUTCOME_BYTES, f"{field} {text}: {n} values", "use fewer values")
        if len(parts) == 4:
            if start <= 0 or stop <= 0:
                raise ConfigError(field, f"{rhs!r}: a log range needs START, STOP > 0", fix=fix)
            values = np.geomspace(start, stop, n)
        else:
            values = np.linspace(start, stop, n)
    if values.size == 0 or not np.all(np.isfinite(values)):
        raise ConfigError(field, f"{text!r} gives no finite values", fix=fix)
    return Vary(paths, values, scale)


class Grid:
    """Every combination of the axes' values, numbered in C order (the last axis fastest)."""

    def __init__(self, axes: list[Vary], cfg: Section, field: str = "--vary"):
        self.axes = list(axes)
        self.cfg = cfg
        self.field = field
        self.shape = tuple(len(a.values) for a in self.axes)
        with_overrides(cfg, self.point(0).overrides, field)      # bad paths fail here, once

    @property
    def labels(self) -> list[str]:
        return [a.label for a in self.axes]

    def __len__(self) -> int:
        return math.prod(self.shape)

    def point(self, index: int) -> Point:
        idx = np.unravel_index(index, self.shape)
        values, overrides = {}, {}
        for axis, i in zip(self.axes, idx):
            values[axis.label] = float(axis.values[i])
            overrides.update(axis.overrides(self.cfg, axis.values[i], self.field))
        return Point(int(index), values, overrides)

    def describe(self) -> dict:
        """The grid's identity: its axes and the config they change."""
        return {"grid": [{"paths": a.paths, "scale": a.scale, "values": a.values.tolist()}
                         for a in self.axes], "config": self.cfg.data}


class ValueList:
    """Points that are the values of one named quantity (e.g. a controller gain), not config
    overrides: point ``i`` is ``{name: values[i]}``."""

    def __init__(self, name: str, values):
        self.name = name
        self.values = np.asarray(values, dtype=float)

    @property
    def labels(self) -> list[str]:
        return [self.name]

    def __len__(self) -> int:
        return len(self.values)

    def point(self, index: int) -> Point:
        return Point(int(index), {self.name: float(self.values[index])}, {})

    def describe(self) -> dict:
        return {"values": {self.name: self.values.tolist()}}


# -- random samples -------------------------------------------------------------------------------
#: distribution name -> (parameter names, draw(rng, *params), check of the parameters)
DISTRIBUTIONS = {
    "normal": (("mean", "std"), lambda rng, m, s: rng.normal(m, s), lambda m, s: s >= 0),
    "uniform": (("low", "high"), lambda rng, lo, hi: rng.uniform(lo, hi), lambda lo, hi: hi > lo),
    "lognormal": (("mu", "sigma"), lambda rng, m, s: rng.lognormal(m, s), lambda m, s: s >= 0),
}


@dataclass(frozen=True)
class SampleAxis(ConfigAxis):
    """One axis of a random sample: config paths that take a value drawn from a distribution."""

    paths: tuple[str, ...]
    distribution: str
    params: tuple[float, ...]
    scale: bool = False

    def draw(self, rng: np.random.Generator) -> float:
        return float(DISTRIBUTIONS[self.distribution][1](rng, *self.params))


def parse_sample(text: str, field: str = "--sample") -> SampleAxis:
    """``PATHS=DIST(A, B)`` or ``PATHS*=DIST(A, B)`` (module docstring) -> :class:`SampleAxis`."""
    fix = ("write PATH[,PATH...]=normal(MEAN, STD), =uniform(LOW, HIGH) or =lognormal(MU, SIGMA), "
           "or *= for a factor, e.g. foundation.stiffness_n_per_m.z*=normal(1, 0.1)")
    paths, scale, rhs = _split_axis(text, field, fix)
    match = re.fullmatch(r"(\w+)\s*\((.*)\)", rhs)
    if not match or match.group(1) not in DISTRIBUTIONS:
        raise ConfigError(field, f"{rhs!r} is not one of " + ", ".join(
            f"{name}({', '.join(spec[0])})" for name, spec in DISTRIBUTIONS.items()), fix=fix)
    names, _, valid = DISTRIBUTIONS[match.group(1)]
    try:
        params = tuple(float(v) for v in match.group(2).split(","))
    except ValueError:
        raise ConfigError(field, f"{rhs!r}: the parameters are not numbers", fix=fix) from None
    if len(params) != len(names) or not all(map(math.isfinite, params)) or not valid(*params):
        raise ConfigError(field, f"{rhs!r}: need finite {', '.join(names)}"
                          + {"normal": " with STD >= 0", "uniform": " with HIGH > LOW",
                             "lognormal": " with SIGMA >= 0"}[match.group(1)], fix=fix)
    return SampleAxis(paths, match.group(1), params, scale)


class Sample:
    """``n`` points, point ``i`` drawn from child ``i`` of the study ``seed`` (module docstring)."""

    def __init__(self, axes: list[SampleAxis], n: int, seed: int, cfg: Section,
                 field: str = "--sample"):
        if not axes:
            raise ConfigError(field, "no distribution given",
                              fix="give --sample PATH=normal(MEAN, STD) at least once")
        if n < 1:
            raise ConfigError("--n", f"need at least one point (got {n})", fix="give --n 1000")
        if seed < 0:
            raise ConfigError("--seed", f"must be >= 0 (got {seed})", fix="give --seed 0")
        self.axes = list(axes)
        self.n = int(n)
        self.seed = int(seed)
        self.cfg = cfg
        self.field = field
        with_overrides(cfg, self.point(0).overrides, field)

    @property
    def labels(self) -> list[str]:
        return [a.label for a in self.axes]

    def __len__(self) -> int:
        return self.n

    def point(self, index: int) -> Point:
        rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(int(index),)))
        values, overrides = {}, {}
        for axis in self.axes:
            value = axis.draw(rng)
            values[axis.label] = value
            overrides.update(axis.overrides(self.cfg, value, self.field))
        return Point(int(index), values, overrides)

    def describe(self) -> dict:
        """The sample's identity -- axes, seed and the config they change, not the number of
        points: a study with more (or fewer) points shares its first points with this one."""
        return {"sample": [{"paths": a.paths, "scale": a.scale, "distribution": a.distribution,
                            "params": a.params} for a in self.axes], "seed": self.seed,
                "config": self.cfg.data}
