"""Is a bag what its index, statistics and schemas say? One streaming pass over the data.

A reader that seeks through an MCAP file by its index (this package's series path, Foxglove,
``ros2 bag play``) trusts the message indexes, chunk indexes and statistics. :func:`scan_bag`
checks them instead of trusting them: it reads the file record by record (:mod:`.records`,
one chunk in memory at a time, so memory is independent of the file's size) and compares what
the **data** holds with

* the CRCs: each chunk's CRC of its uncompressed records, the data-section CRC of the DataEnd
  record and the summary CRC of the Footer, where the writer stored them (non-zero);
* each chunk's MessageIndex records (every message's log time and offset, per channel) and the
  chunk's own start/end times;
* the summary: schemas and channels, the Statistics record (message count, per-channel counts,
  start/end times, chunk, schema, channel and metadata counts), the ChunkIndex records (offset,
  length, times, message-index offsets, compression, sizes) and the MetadataIndex records;
* the ``rosbag2`` metadata record (``metadata.yaml``: per-topic types and counts, start,
  duration, QoS strings) and the package's ``rotor_avc_counts`` record (messages recorded);
* the schemas: every message decodes with the ``ros2msg`` text its channel names; for a type
  whose standard definition the package knows (:mod:`.msgdefs`) the text defines exactly that
  type; the channel's ``topic_type_hash`` (RIHS01) is the hash of that text; a topic of the
  package (:mod:`.topics`) in a bag of the package carries its own type (:mod:`.schema_check`);
* duplicates, per topic: the same log time and the same bytes twice, and two different messages
  for one sample (same log time) on a sampled topic (:data:`.topics.SAMPLED`). The lockstep
  plant resends an unanswered sample, so up to :data:`RESENDS_ALLOWED` of a sampled topic's
  messages may repeat one (a bag written twice repeats every one of them).

Missing samples are :mod:`.sequence`'s job (it reads the message indexes, which this pass
proves right). :func:`verify` raises :class:`~.errors.CorruptBagError` (exit status 4) listing
the problems with where they are (topic, record offset, sample time).
"""
from __future__ import annotations

from pathlib import Path

from .errors import CorruptBagError, no_such_bag
from .integrity_pass import _Pass
from .integrity_report import (PROBLEMS_KEPT, RESENDS_ALLOWED, IntegrityReport, Problem,
                               TopicData)

__all__ = ["PROBLEMS_KEPT", "RESENDS_ALLOWED", "IntegrityReport", "Problem", "TopicData",
           "scan_bag", "verify"]


def verify(path) -> IntegrityReport:
    """:func:`scan_bag`, raising :class:`CorruptBagError` unless the bag is consistent."""
    report = scan_bag(path)
    if not report.ok:
        raise CorruptBagError(report.path, report.problem_count, report.verdict())
    return report


def scan_bag(path, progress=None) -> IntegrityReport:
    """The integrity report of the ``.mcap`` file ``path`` (see the module docstring);
    ``progress``: called ``(MB read, MB of the file)`` as the pass goes (None: quiet)."""
    path = Path(path)
    if not path.is_file():
        raise no_such_bag(path)
    with open(path, "rb") as f:
        return _Pass(path, f, progress).run()
