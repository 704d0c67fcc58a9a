"""``frf.uff``: the comparison's FRFs as Universal File Format type 58 records (pyuff), the
exchange format modal and vibration tools read.

Per broadband dwell and output: the measured H1 (function type 4, FRF), its coherence (type 6)
and the sampled-loop and continuous models' FRFs (type 4), complex, over the estimate's evenly
spaced frequencies in the test band; per 1x channel: the measured 1x response and both models
over the measured rotational frequencies (uneven abscissa, two speeds or more), per unit
unbalance. Units are SI:
the ordinate's data type, length/force exponents and label (``m/s^2``, ``m/s``, ``N``), the
denominator's (``N`` for the test force; the unbalance's unit for 1x). Response node = 1-based
index of the channel in the record set, direction 1/2/3 = x/y/z of the channel's axis; the
reference node is the test force's actuator. ``id1`` names the function and channel, ``id2``
the source (measured / model), ``id3`` the speed and the estimate's averages.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pyuff

from ..compare.comparison import Comparison
from ..output_files import writing

FRF, COHERENCE = 4, 6
#: UFF specific data types and SI unit exponents (length, force) by unit label
UNITS = {"m": (8, 1, 0), "m/s": (11, 1, 0), "m/s^2": (12, 1, 0), "N": (13, 0, 1),
         "kg m": (0, 1, 0), "kg m^2": (0, 2, 0)}
FREQUENCY = 18
DIRECTION = {"x": 1, "y": 2, "z": 3}


def _unit_fields(prefix: str, unit: str) -> dict:
    kind, length, force = UNITS.get(unit, (0, 0, 0))
    return {f"{prefix}_spec_data_type": kind, f"{prefix}_len_unit_exp": length,
            f"{prefix}_force_unit_exp": force, f"{prefix}_temp_unit_exp": 0,
            f"{prefix}_axis_units_lab": unit}


def _record(func_type, name, node, ref_node, ids, freq_hz, values, unit, denom):
    freq_hz = np.asarray(freq_hz, dtype=float)
    step = np.diff(freq_hz)
    even = step.size > 0 and bool(np.allclose(step, step[0], rtol=1e-9))
    record = pyuff.prepare_58(
        binary=0, id1=ids[0][:80], id2=ids[1][:80], id3=ids[2][:80], id4="rotor_avc compare",
        id5="NONE", func_type=func_type, ver_num=0, load_case_id=0, rsp_ent_name=name[:10],
        rsp_node=node, rsp_dir=DIRECTION.get(name[-1], 0), ref_ent_name="force",
        ref_node=ref_node, ref_dir=3, z_axis_value=0.0, abscissa_spec_data_type=FREQUENCY,
        abscissa_len_unit_exp=0, abscissa_force_unit_exp=0, abscissa_temp_unit_exp=0,
        abscissa_axis_units_lab="Hz", **_unit_fields("ordinate", unit),
        **_unit_fields("orddenom", denom), z_axis_spec_data_type=0, z_axis_len_unit_exp=0,
        z_axis_force_unit_exp=0, z_axis_temp_unit_exp=0, z_axis_axis_units_lab="",
        data=np.asarray(values), x=freq_hz)
    record.update(abscissa_spacing=int(even), abscissa_inc=float(step[0]) if even else 0.0,
                  abscissa_axis_lab="frequency", ordinate_axis_lab=name[:20],
                  orddenom_axis_lab="force" if denom == "N" else denom, z_axis_axis_lab="")
    return record


def uff_records(comp: Comparison) -> list[dict]:
    """Every record of :func:`write_uff` as pyuff dicts."""
    records, nodes = [], {}
    plant = comp.run.machine.plant
    actuators = [a.id for a in plant.actuators]
    for bb in comp.broadband:
        est = bb.estimate
        sel = np.isin(est.freq_hz, bb.models["sampled"].freq_hz)
        f = est.freq_hz[sel]
        test = comp.run.scenario.test_force
        ref = actuators.index(test.actuator) + 1
        where = f"at {bb.speed_rad_s / (2 * np.pi):.3f} Hz, {est.averages} averages"
        for i, name in enumerate(bb.outputs):
            node = nodes.setdefault(name, len(nodes) + 1)
            unit = bb.models["sampled"].units[name].split("/N")[0]
            ids = (f"H1 {name} / {test.channel}", "measured", where)
            records.append(_record(FRF, name, node, ref, ids, f, est.h1[sel, i], unit,
                                   "N"))
            records.append(_record(COHERENCE, name, node, ref,
                                   (f"coherence {name} / {test.channel}", "measured", where),
                                   f, est.coherence[sel, i].astype(float), "", ""))
            for m in ("sampled", "continuous"):
                records.append(_record(FRF, name, node, ref,
                                       (f"H {name} / {test.channel}", f"{m} model", where), f,
                                       bb.models[m].responses[name], unit, "N"))
    one = comp.one_x
    if one is not None and one.speed_rad_s.size >= 2:      # a function needs two abscissae
        f = one.speed_rad_s / (2 * np.pi)
        for name, meas in one.measured.items():
            node = nodes.setdefault(name, len(nodes) + 1)
            unit, _, denom = one.units[name].partition("/(")
            denom = denom.rstrip(")")
            for source, values in (("measured", meas), ("sampled model", one.model["sampled"][name]),
                                   ("continuous model", one.model["continuous"][name])):
                records.append(_record(FRF, name, node, 0,
                                       (f"1x {name} per unit unbalance", source, one.reference),
                                       f, values, unit, denom))
    return records


def write_uff(comp: Comparison, path) -> Path | None:
    """Write ``path`` (UFF type 58, ASCII); None when the comparison has no FRF."""
    records = uff_records(comp)
    if not records:
        return None
    path = Path(path)
    with writing(path) as tmp:
        pyuff.UFF(str(tmp)).write_sets(records, mode="add")
    return path
