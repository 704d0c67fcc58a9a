"""What every recording format's reader offers (:func:`rotor_avc.bag.rosbag2.open_bag` returns
one): the topics and their counts, the run configuration a bag of this package carries, decoded
messages in log-time order, and whole or chunked numeric series of a topic. A new format (a
directory of split files, another container) implements this protocol in one module and is added
to ``open_bag``; every reader of recordings above ``bag/`` (compare, calibrate, runup, replay)
uses only these members. :class:`rotor_avc.bag.reader.BagReader` reads one MCAP file (and more:
its chunk indexes, the lockstep record), :class:`rotor_avc.bag.rosbag2.DirectoryBag` a rosbag2
directory of split MCAP files (``test/test_seams.py`` checks both against this protocol)."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Iterator, Protocol, runtime_checkable

import numpy as np

from .reader import BagMessage, TopicInfo
from .series import TopicSeries


@runtime_checkable
class RecordingReader(Protocol):
    path: Path

    @property
    def topics(self) -> dict[str, TopicInfo]: ...

    @property
    def message_count(self) -> int: ...

    @property
    def time_range_ns(self) -> tuple[int, int]: ...

    @property
    def metadata(self) -> dict[str, dict[str, str]]: ...

    @property
    def config(self) -> dict[str, Any]: ...

    @property
    def counts(self) -> dict[str, dict[str, int | None]] | None: ...

    def codec(self, topic: str): ...

    def raw_messages(self, topics=None, start_ns=None, end_ns=None) -> Iterator[BagMessage]: ...

    def messages(self, topics=None, start_ns=None, end_ns=None) -> Iterator[BagMessage]: ...

    def series(self, topic: str) -> TopicSeries: ...

    def series_chunks(self, topic: str) -> Iterator[TopicSeries]: ...

    def log_times(self, topic: str) -> np.ndarray: ...

    def chunk_log_times(self, topics) -> Iterator[tuple[int, dict[str, np.ndarray]]]: ...

    def close(self) -> None: ...

    def __enter__(self): ...

    def __exit__(self, *exc) -> None: ...
