"""What a comparison reads of a recorded run (:func:`rotor_avc.compare.comparison.compare_run`):
the run's scenario and configuration, what was found while reading it (notes, assumptions), its
channels, and its constant-speed dwells; a source that fits the 1x at the samples' own stamps
brings its ``tracking``, a source on one sample grid its ``blocks`` instead.

Implemented by :class:`~rotor_avc.compare.recorded_run.RecordedRun` (a run read whole: a bag in
memory, a mapped recording resampled onto a grid), :class:`~rotor_avc.compare.bag_source.BagSource`
(a bag of this package streamed block by block) and
:class:`~rotor_avc.compare.mapped_stream.MappedStream` (a mapped recording streamed, each channel
fitted at its own stamps); ``test/test_seams.py`` checks all three against these protocols."""
from __future__ import annotations

from pathlib import Path
from typing import Iterator, Protocol, runtime_checkable

from ..scenario import Scenario


@runtime_checkable
class RunSource(Protocol):
    path: Path
    scenario: Scenario
    config: dict
    namespace: str
    test_source: str
    notes: list[str]
    #: what a recording of a real machine left to assumption, each value with its source
    assumptions: dict
    #: ``(names, u_ref, runup_revolutions) -> (track, method, settings)`` or None
    tracking: object
    #: ``(outputs, freq_hz) -> gain`` of the resampling on an FRF, or None
    interpolation: object
    channel_names: list[str]
    has_test_force: bool

    @property
    def sample_period_s(self) -> float: ...

    @property
    def machine(self): ...

    def dwells(self) -> Iterator: ...


@runtime_checkable
class GridRunSource(RunSource, Protocol):
    """A run on one sample grid (its ``tracking`` None): the comparison tracks it block by
    block."""

    def blocks(self) -> Iterator: ...
