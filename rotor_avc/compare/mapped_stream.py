"""A recording of any machine compared without holding it: the run source of ``rotor-avc compare
BAG --config MACHINE --map MAP`` for a recording without a test force (the 1x comparison needs
no sample grid), in memory flat in the recording's length.

The shaft topic is read first and whole (a tacho's pulses are one message per revolution; an
encoder's angle is one value per sample); it gives the shaft angle with its revolutions counted,
the constant-speed dwells and the order-tracking windows (rotor_avc.compare.mapped_run:
``shaft_windows``). Then each mapped topic is read chunk by chunk
(:meth:`rotor_avc.bag.reader.BagReader.series_chunks`), every mapped field of it cleaned as it
comes (:class:`rotor_avc.analysis.stamp_stream.StampStream`: excluded values, clock steps,
stamps out of order, rate, jitter, dropouts) and fitted window by window at the shaft angle of
its own stamps (:class:`rotor_avc.analysis.window_tracking.WindowFits`), keeping one window and
one chunk. A run-up's windows are those inside the time every channel covers. The notes and
assumptions are those of :func:`~rotor_avc.compare.mapped_run.read_mapped_run`, which reads a
recording whole onto a grid -- the source for a broadband test force, for ``--in-memory`` and
for the run-up views (waterfall, orbits) of ``rotor-avc runup``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..analysis.resampling import OVERFLOW
from ..analysis.stamp_stream import StampStream
from ..analysis.window_tracking import WindowFits, assemble
from ..bag.rosbag2 import open_bag
from .comparison import RUNUP_REVOLUTIONS, Comparison, compare_run
from .mapped_run import (band_notes, clock_error, field_values, gap_notes,
                         load_machine_and_map, noise_notes, read_mapped_run, read_shaft,
                         require_topic, shaft_of, shaft_windows, too_few, top_speed_hz,
                         within_channels)
from .recording_scenario import describe_assumptions, recording_scenario


class MappedStream:
    """The comparison's view of a mapped recording (the metadata of
    :class:`~rotor_avc.compare.recorded_run.RecordedRun` and its ``tracking``), read in one
    streaming pass per mapped topic (module docstring)."""

    #: a recording without a test force has no broadband dwells
    has_test_force = False
    test_source = ""
    namespace = ""
    interpolation = None

    def __init__(self, bag_path, config, map_path, loaded=None):
        self.path = Path(bag_path)
        config_path, self.config, machine, rmap, signals = (
            loaded or load_machine_and_map(config, map_path))
        source = str(map_path)
        with open_bag(bag_path, require_messages=True, integrity=True) as bag:
            shaft_ns, shaft_angle = read_shaft(bag, rmap.shaft, source)
            origin_ns = int(shaft_ns.min())
            shaft_s = (shaft_ns - origin_ns) * 1e-9
            self.shaft, shaft_note = shaft_of(rmap.shaft, shaft_s, shaft_angle, np.zeros(0))
            self.windows, gapped, self.method, self.settings = shaft_windows(
                self.shaft, RUNUP_REVOLUTIONS)
            streams, fits = self._read_channels(bag, signals, origin_ns, source)
        notes = []
        for name, stream in streams.items():
            notes.append(stream.quality().describe() + (
                f", {stream.excluded} values not finite or beyond {OVERFLOW:g} excluded"
                if stream.excluded else ""))
        start = max(s.first_s for s in streams.values())
        stop = min(s.last_s for s in streams.values())
        if not self.shaft.dwells:
            keep = [k for k, (t0, t1, _) in enumerate(self.windows) if t0 >= start and t1 <= stop]
            self.windows, gapped = within_channels(self.windows, gapped, start, stop)
            fits = {name: [f[k] for k in keep] for name, f in fits.items()}
        self.fits, self.skipped = fits, gap_notes(gapped)
        self.scenario, self.assumptions = recording_scenario(
            self.config, str(config_path), rmap, machine,
            {name: s.quality().rate_hz for name, s in streams.items()}, stop - start,
            top_speed_hz(rmap.shaft, shaft_s, shaft_angle))
        notes.append(shaft_note)
        notes.append("order tracking streamed: each channel fitted at its own stamps in "
                     f"{len(self.windows)} shaft windows, read chunk by chunk (no resampling "
                     "grid)")
        notes.append("assumed: " + describe_assumptions(self.assumptions))
        self.notes = notes
        self.channel_names = list(signals)

    def _read_channels(self, bag, signals, origin_ns: int, source: str):
        """One pass per mapped topic: ``(streams, fits)`` per channel (module docstring)."""
        streams = {name: StampStream(f"{name} ({sig.topic})") for name, sig in signals.items()}
        tracks = {name: WindowFits(self.shaft.knots, self.windows) for name in signals}
        topics: dict[str, list[str]] = {}
        for name, sig in signals.items():
            require_topic(bag, sig.topic, f"channels.{name}", source)
            topics.setdefault(sig.topic, []).append(name)
        for topic, names in topics.items():
            for series in bag.series_chunks(topic):
                for name in names:
                    sig, where = signals[name], f"channels.{name}"
                    stamps, values = field_values(series, sig, where, source)
                    t, y = streams[name].add((stamps - origin_ns) * 1e-9,
                                             sig.sign * sig.scale * values,
                                             None if sig.stamp == "log" else series.time_ns * 1e-9)
                    if streams[name].clock_step is not None:
                        raise clock_error(topic, where, source, streams[name].clock_step, 1,
                                          origin_ns * 1e-9)
                    tracks[name].add(t, y)
        for name, stream in streams.items():
            stream.finish_clock()
            sig = signals[name]
            if stream.clock_step is not None:
                raise clock_error(sig.topic, f"channels.{name}", source, stream.clock_step, 1,
                                  origin_ns * 1e-9)
            if stream.samples < 3:
                raise too_few(sig, f"channels.{name}", source, stream.samples,
                              stream.samples + stream.excluded)
        return streams, {name: t.close() for name, t in tracks.items()}

    sample_period_s = property(lambda self: self.scenario.sample_period_s)
    machine = property(lambda self: self.scenario.machine)

    def dwells(self):
        """No broadband dwells (a recording without a test force)."""
        return iter(())

    def tracking(self, names, u_ref, runup_revolutions: int):
        """The 1x track of ``names`` over the windows fitted while reading: ``(track, method,
        settings)``; windows left out, and noisy points, are added to the notes."""
        if runup_revolutions != RUNUP_REVOLUTIONS:
            raise ValueError(f"the windows were cut for {RUNUP_REVOLUTIONS} revolutions")
        track, notes = assemble(self.windows, {n: self.fits[n] for n in names}, u_ref)
        self.notes += self.skipped + notes + noise_notes(track, self.method)
        return track, self.method, dict(self.settings,
                                        windows_left_out=len(self.skipped) + len(notes))


def compare_mapped(bag_path, config, map_path, in_memory: bool = False) -> Comparison:
    """Compare a recording through a mapping: streamed (:class:`MappedStream`), or read whole
    onto a grid (:func:`~.mapped_run.read_mapped_run`) when it has a test force or with
    ``in_memory``; with :func:`~.mapped_run.band_notes`."""
    loaded = load_machine_and_map(config, map_path)
    streamed = not in_memory and loaded[3].test_force is None
    comp = compare_run(MappedStream(bag_path, config, map_path, loaded) if streamed
                       else read_mapped_run(bag_path, config, map_path, loaded))
    comp.notes += band_notes(comp)
    return comp
