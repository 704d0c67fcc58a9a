"""ISO 20816-3 zones of a recorded run's bearing-housing vibration (``rotor-avc compare`` and
``rotor-avc runup``; :mod:`rotor_avc.analysis.iso20816`).

Channels: ``analysis.iso20816.channels`` of the run's machine, by default the plant's
bearing-housing outputs (:func:`rotor_avc.compare.runup_views.housing_channels`: Werner 2021's
``bearing_D_v*``/``bearing_N_v*``, Werner 2019's ``bearing_v*``, Werner 2017's ``housing_v*``,
the active bearing's ``housing_<i>_<axis>`` displacements, the rigid rotor's ``bearing_*``),
each direction one entry; velocities as recorded, accelerations integrated and displacements
differentiated in the frequency domain within the band.

Value per channel: the largest band-limited r.m.s. velocity over windows of :data:`WINDOW_S`
(hop half a window) -- in a comparison of a run with constant-speed dwells, within the settled
second half of each dwell (the comparison's 1x windows); otherwise (a run-up, and always in
``rotor-avc runup``) over the whole run, block by block, windows across the blocks. The band
follows the run's top speed (:func:`rotor_avc.analysis.iso20816.band_hz`).
"""
from __future__ import annotations

import numpy as np

from ..analysis.iso20816 import BAND_TOP_HZ, WindowMax, band_hz, zone
from ..errors import ConfigError
from .runup_views import _outputs, housing_channels

#: window of the sliding r.m.s. [s]
WINDOW_S = 1.0
FIELD = "analysis.iso20816.channels"
ORDERS = {0: "displacement, differentiated", 1: "velocity", 2: "acceleration, integrated"}


def iso_channels(run) -> list[str]:
    """The run's channels to evaluate: declared (each an output of the plant) or the default."""
    declared = run.machine.analysis.iso20816.channels
    if declared is None:
        return [c for c in housing_channels(run) if _outputs(run)[c].order in ORDERS]
    outputs = _outputs(run)
    for name in declared:
        if name not in outputs or outputs[name].order not in ORDERS:
            raise ConfigError(FIELD, f"{name!r} is no displacement, velocity or acceleration "
                              "output of the plant",
                              fix=f"choose from {', '.join(o for o in outputs)}",
                              source=str(run.machine.config.source))
    return list(declared)


def iso20816_entries(run, whole_run: bool = False) -> tuple[list[dict], list[str]]:
    """``(entries, notes)``: one entry per channel recorded, ``{channel, rms_mm_s, zone, group,
    support, band_hz, quantity, windows}``, over the dwells or (``whole_run``, or a run without
    dwells) the whole run (module docstring)."""
    settings = run.machine.analysis.iso20816
    channels = iso_channels(run)
    recorded = [c for c in channels if c in run.channel_names]
    notes = [f"ISO 20816-3: {c} not recorded" for c in channels if c not in recorded]
    if not recorded:
        return [], notes + ["ISO 20816-3: no bearing-housing channel to evaluate"]
    T = run.sample_period_s
    band = band_hz(run.scenario.profile.max_speed_rad_s / (2 * np.pi), 1.0 / T)
    if band[1] < BAND_TOP_HZ:
        notes.append(f"ISO 20816-3: the band ends at the Nyquist frequency {band[1]:g} Hz of the "
                     f"run's sample rate, not at {BAND_TOP_HZ:g} Hz")
    outputs = _outputs(run)
    meters = {c: WindowMax(int(round(WINDOW_S / T)), T, outputs[c].order, band) for c in recorded}
    has_dwells = False
    for d in () if whole_run else run.dwells():
        has_dwells = True
        for c, m in meters.items():
            m.add(d.channels[c][d.settle_start:])
            m.end()
    if not has_dwells:
        if not hasattr(run, "blocks"):
            return [], notes + ["ISO 20816-3: a mapped recording streamed at its channels' "
                                "own stamps is not evaluated (compare it with --in-memory)"]
        for block in run.blocks():
            for c, m in meters.items():
                m.add(block[3][c])
        for m in meters.values():
            m.end()
    entries = []
    for c, m in meters.items():
        if not m.windows:
            notes.append(f"ISO 20816-3: {c} has too few samples for a window")
            continue
        rms = 1e3 * m.max_rms
        entries.append({"channel": c, "rms_mm_s": rms,
                        "zone": zone(rms, settings.group, settings.support),
                        "group": settings.group, "support": settings.support,
                        "band_hz": list(band), "quantity": ORDERS[outputs[c].order],
                        "windows": m.windows})
    return entries, notes


def format_iso_table(entries: list[dict]) -> str:
    """The entries as one terminal table."""
    if not entries:
        return "ISO 20816-3: no bearing-housing channel evaluated"
    e0 = entries[0]
    lines = [f"ISO 20816-3 (group {e0['group']}, {e0['support']} support, "
             f"{e0['band_hz'][0]:g} .. {e0['band_hz'][1]:g} Hz, max of {WINDOW_S:g} s windows):",
             f"  {'channel':24s} {'rms [mm/s]':>11}  zone  quantity"]
    lines += [f"  {e['channel']:24s} {e['rms_mm_s']:11.4g}  {e['zone']:4s}  {e['quantity']}"
              for e in entries]
    return "\n".join(lines)
