"""Measured FRFs from Universal File Format type 58 files (what modal and vibration tools export)
as calibration targets, through a mapping file (``--uff-map``)::

    uff:
      input: DL                 # the actuator at whose point the force was applied (reference)
      speed_hz: 0.0             # shaft speed during the test (0: standstill)
      averages: 40              # averages of the H1 estimate (random error from the coherence)
      responses:                # UFF response node and direction -> model signal
        - {node: 11, direction: 3, signal: foot_DL_az}
        - {node: 21, direction: -3, signal: bearing_D_vz}     # a negative direction: sign -1
      band_hz: [5.0, 200.0]     # optional: the frequencies used

Records: per response an FRF (function type 4) with that response node and direction (and
``reference_node`` when given), all on the same frequencies; a coherence record (type 6) of the
same node and direction gives each bin's normalised random error
``eps = sqrt(1 - coh) / (sqrt(coh) sqrt(2 averages))`` (Bendat & Piersol, random data, eq. 9.73)
and leaves out bins below ``min_coherence``; without coherence records ``relative_std`` is each
bin's relative standard uncertainty. Values in SI (a units record, type 164, other than SI is
refused); the ordinate's data type (8 displacement, 11 velocity, 12 acceleration) must be the
model signal's quantity, the denominator a force (13) -- both checked where the file states them.

The model of the points is the continuous closed loop at ``speed_hz`` with the hysteretic damping
model (``w_F = max(w, floor)`` per frequency, rotor_avc.analysis.transfer): a measured FRF is
analogue, not a sampled sequence.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..analysis.frf_estimate import h1_random_error
from ..analysis.transfer import quantity
from ..compare.checks import MIN_COHERENCE
from ..compare.mapped_run import model_signals
from ..config import load_yaml
from ..section import Section
from ..errors import ConfigError, path_suggestion
from ..settings import read_settings, setting
from .targets import BandPoints, Target

FRF, COHERENCE, UNITS_RECORD = 4, 6, 164
#: UFF ordinate data type of a quantity by its time-derivative order; a force
DATA_TYPE = {0: 8, 1: 11, 2: 12}
FORCE = 13
SUFFIXES = (".uff", ".unv")


@dataclass(frozen=True)
class UffResponse:
    """One measured response."""

    node: int = setting(doc="UFF response node (rsp_node)", minimum=0)
    direction: int = setting(doc="UFF response direction (rsp_dir): 1, 2, 3 = x, y, z; negative: "
                                 "the model signal is the recorded value times -1",
                             minimum=-6, maximum=6)
    signal: str = setting(doc="the model signal: an output, foot_<id>_a<axis> or "
                              "actuator_<id>_f<axis>")


@dataclass(frozen=True)
class UffMap:
    """Which UFF records are which model FRFs (module docstring)."""

    input: str = setting(doc="actuator id at whose point the measured force acts")
    responses: tuple[UffResponse, ...] = setting(doc="the measured responses", min_length=1)
    speed_hz: float = setting(0.0, "shaft speed during the test", unit="Hz", nonnegative=True)
    reference_node: int | None = setting(None, "UFF reference node (ref_node) of the force "
                                         "(default: any)", minimum=0)
    averages: int | None = setting(None, "averages of the H1 estimate (with coherence records)",
                                   minimum=1)
    relative_std: float | None = setting(None, "relative standard uncertainty of every bin "
                                         "(without coherence records)", positive=True)
    min_coherence: float = setting(MIN_COHERENCE, "bins below this coherence are left out",
                                   minimum=0.0, maximum=1.0)
    band_hz: tuple[float, ...] | None = setting(None, "[low, high]: the frequencies used",
                                                unit="Hz", min_length=2)


def read_uff_map(path) -> UffMap:
    sec = Section(load_yaml(path), "", str(path))
    sec.check_keys(["uff"])
    return read_settings(UffMap, sec.section("uff"))


def is_uff(path) -> bool:
    return Path(path).suffix.lower() in SUFFIXES


def _sets(path: Path) -> list[dict]:
    if not path.is_file():
        raise ConfigError(str(path), "no such UFF file" + path_suggestion(path),
                          fix="check the path")
    import pyuff                                    # imported only to read such a file
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:    # noqa: BLE001 -- pyuff raises anything on a malformed file
        raise ConfigError(str(path), f"not a readable UFF file ({type(exc).__name__}: {exc})",
                          fix="export the FRFs as UFF type 58 (ASCII or binary)") from None
    return [sets] if isinstance(sets, dict) else list(sets)


def _record(sets, path, where, func_type, node, direction, ref_node):
    found = [s for s in sets if s.get("type") == 58 and s.get("func_type") == func_type
             and s.get("rsp_node") == node and abs(s.get("rsp_dir", 0)) == abs(direction)
             and (ref_node is None or s.get("ref_node") == ref_node)]
    if len(found) > 1:
        raise ConfigError(where, f"{len(found)} records of function type {func_type} for node "
                          f"{node} direction {direction} in {path}",
                          fix="give uff.reference_node to pick one")
    return found[0] if found else None


def uff_target(path, umap: UffMap, plant, map_source: str) -> Target:
    """The measured FRFs of ``path`` as a calibration target (module docstring)."""
    path = Path(path)
    sets = _sets(path)
    for s in sets:
        if s.get("type") == UNITS_RECORD and s.get("units_code", 1) != 1:
            raise ConfigError(str(path), f"units record {s.get('units_code')} "
                              f"({s.get('units_description', '').strip()}) is not SI",
                              fix="export the FRFs in SI units")
    signals = model_signals(plant)
    try:
        plant.actuator(umap.input)
    except Exception:             # noqa: BLE001 -- the plant names its actuators
        raise ConfigError("uff.input", f"{umap.input!r} is not an actuator of the machine",
                          fix="use one of " + ", ".join(a.id for a in plant.actuators),
                          source=map_source) from None
    freq, columns, sigmas, used, left_out, outputs = None, [], [], [], [], []
    for i, resp in enumerate(umap.responses):
        where = f"uff.responses[{i}]"
        if resp.signal not in signals:
            raise ConfigError(f"{where}.signal", f"{resp.signal!r} is not a signal of the "
                              "machine", fix="use one of " + ", ".join(signals), source=map_source)
        rec = _record(sets, path, where, FRF, resp.node, resp.direction, umap.reference_node)
        if rec is None:
            raise ConfigError(where, f"no FRF (function type 4) for node {resp.node} direction "
                              f"{resp.direction} in {path}", fix="map a response the file holds",
                              source=map_source)
        _check_units(rec, plant, resp.signal, where, map_source)
        x = np.asarray(rec["x"], float)
        if freq is None:
            freq = x
        elif x.shape != freq.shape or not np.allclose(x, freq, rtol=1e-9):
            raise ConfigError(where, "its frequencies differ from the first response's",
                              fix="export every FRF on the same frequency lines",
                              source=map_source)
        sign = -1.0 if resp.direction < 0 else 1.0
        h = sign * np.asarray(rec["data"], complex)
        coh_rec = _record(sets, path, where, COHERENCE, resp.node, resp.direction,
                          umap.reference_node)
        keep = np.isfinite(h) & (freq > 0)
        if umap.band_hz is not None:
            keep &= (freq >= umap.band_hz[0]) & (freq <= umap.band_hz[1])
        if coh_rec is not None:
            if umap.averages is None:
                raise ConfigError("uff.averages", "the file has coherence records but the "
                                  "mapping does not say how many averages the H1 had",
                                  fix="give uff.averages", source=map_source)
            coh = np.clip(np.asarray(coh_rec["data"], float).real, 0.0, 1.0)
            low = keep & (coh < umap.min_coherence)
            if low.any():
                left_out.append(f"{path.name}: {int(low.sum())} bins of {resp.signal} below "
                                f"coherence {umap.min_coherence:g}")
            keep &= coh >= umap.min_coherence
            sigma = h1_random_error(np.where(coh > 0, coh, 1.0), umap.averages) * np.abs(h)
        elif umap.relative_std is not None:
            sigma = umap.relative_std * np.abs(h)
        else:
            raise ConfigError("uff.relative_std", f"{path.name} has no coherence record for "
                              f"node {resp.node} direction {resp.direction}",
                              fix="give uff.relative_std, or export the coherence with the FRFs",
                              source=map_source)
        columns.append(h)
        sigmas.append(sigma)
        used.append(keep)
        outputs.append(resp.signal)
    band = BandPoints(2 * np.pi * umap.speed_hz, None, umap.input, outputs, freq,
                      np.column_stack(columns), np.column_stack(sigmas), np.column_stack(used),
                      continuous=True)
    return Target(path.name, None, 1.0, np.zeros(0), [], {}, {}, {}, {}, {}, [band], left_out)


def _check_units(rec: dict, plant, signal: str, where: str, source: str) -> None:
    kind = quantity(plant, signal)
    expected = DATA_TYPE.get(kind[2]) if kind[0] == "row" else FORCE
    stated = rec.get("ordinate_spec_data_type", 0)
    if stated and expected and stated != expected:
        raise ConfigError(where, f"the record's ordinate is of data type {stated}, {signal} is "
                          f"of data type {expected} ({kind[3]})",
                          fix="map the response of the right quantity", source=source)
    denom = rec.get("orddenom_spec_data_type", 0)
    if denom and denom != FORCE:
        raise ConfigError(where, f"the record's denominator is of data type {denom}, not a "
                          f"force ({FORCE})", fix="give FRFs per unit force", source=source)
