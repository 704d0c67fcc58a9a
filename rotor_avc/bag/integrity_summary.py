"""The summary cross-checks of the integrity pass: summary, statistics, records and topics
against what the data section held."""
from __future__ import annotations

import yaml
from mcap.records import Statistics

from . import records as R
from .errors import BagError
from .integrity_report import RESENDS_ALLOWED
from .metadata import CONFIG_RECORD, COUNTS_RECORD, decode_counts, load_yaml
from .rosbag2_info import check_rosbag2_info
from .topics import SAMPLED, message_type


class SummaryChecks:
    """Mixin of :class:`.integrity_pass._Pass`: its checks once the footer is read."""

    def _check_summary(self) -> None:
        rep, s = self.report, self.summary
        rep.summary = {"statistics": bool(s["statistics"]), "chunk_indexes": bool(s["chunk_index"]),
                       "schemas": bool(s["schema"]), "channels": bool(s["channel"]),
                       "metadata_indexes": bool(s["metadata_index"]) or not rep.metadata}
        for schema in s["schema"]:
            if rep.schemas.get(schema.id) != schema:
                rep.add("summary", f"schema {schema.id} ({schema.name})",
                        "differs from the schema record in the data")
        for channel in s["channel"]:
            if rep.channels.get(channel.id) != channel:
                rep.add("summary", f"channel {channel.id} ({channel.topic})",
                        "differs from the channel record in the data")
        for stats in s["statistics"]:
            self._check_statistics(stats)
        found = dict(self.chunks)
        for ci in s["chunk_index"]:
            where = f"chunk index of the chunk at byte {ci.chunk_start_offset}"
            want = found.pop(ci.chunk_start_offset, None)
            if want is None:
                rep.add("chunk_index", where, "no readable chunk starts there")
                continue
            have = {"length": ci.chunk_length, "start": ci.message_start_time,
                    "end": ci.message_end_time, "compression": ci.compression,
                    "compressed": ci.compressed_size, "uncompressed": ci.uncompressed_size,
                    "index_offsets": dict(ci.message_index_offsets),
                    "index_length": ci.message_index_length}
            wrong = [k for k in want if have[k] != want[k]]
            if wrong:
                k = wrong[0]
                rep.add("chunk_index", where, f"{k} is {have[k]!r}, the file has {want[k]!r}")
        if s["chunk_index"]:
            for offset in found:
                rep.add("chunk_index", f"chunk at byte {offset}", "no chunk index lists it")
        self._check_summary_offsets()
        for mi in s["metadata_index"]:
            at = self.metadata_at.get(mi.offset)
            if at != (mi.name, mi.length):
                rep.add("metadata_index", f"metadata {mi.name!r}", f"the index points at byte "
                        f"{mi.offset} (length {mi.length}), where no such record is")

    def _check_summary_offsets(self) -> None:
        """Each SummaryOffset must span exactly the summary's records of its opcode, and the
        footer must point at the first of them."""
        rep, layout = self.report, self.summary_layout
        groups: dict[int, tuple[int, int]] = {}
        for opcode, start, end in layout:
            if opcode != R.OP_SUMMARY_OFFSET:
                first, _ = groups.get(opcode, (start, end))
                groups[opcode] = (first, end)
        for so in self.summary["summary_offset"]:
            span = groups.get(so.group_opcode)
            if span is None and so.group_length == 0:
                continue                        # an empty group (the mcap Writer lists them)
            if span is None or (so.group_start, so.group_start + so.group_length) != span:
                rep.add("summary", f"summary offset of opcode 0x{so.group_opcode:02x}",
                        f"says bytes {so.group_start}+{so.group_length}, the records are at "
                        f"{span}")
        offsets = [start for opcode, start, _ in layout if opcode == R.OP_SUMMARY_OFFSET]
        if self.footer is not None and self.footer.summary_offset_start != (offsets[0] if offsets
                                                                            else 0):
            rep.add("summary", "footer", f"summary_offset_start is "
                    f"{self.footer.summary_offset_start}, the summary offsets start at "
                    f"{offsets[0] if offsets else 0}")

    def _check_statistics(self, stats: Statistics) -> None:
        rep = self.report
        counts = {cid: t.count for cid, t in rep.topics.items()}
        starts = [t.start_ns for t in rep.topics.values() if t.count]
        ends = [t.end_ns for t in rep.topics.values() if t.count]
        want = {"message_count": rep.message_count, "chunk_count": rep.chunks,
                "schema_count": len(rep.schemas), "channel_count": len(rep.channels),
                "metadata_count": len(self.metadata_at),
                "message_start_time": min(starts) if starts else 0,
                "message_end_time": max(ends) if ends else 0}
        for key, value in want.items():
            if getattr(stats, key) != value:
                rep.add("statistics", "statistics record",
                        f"{key} is {getattr(stats, key)}, the data has {value}")
        for cid, n in stats.channel_message_counts.items():
            if counts.get(cid, 0) != n:
                rep.add("statistics", self._name(cid),
                        f"the statistics count {n} message(s), the data holds {counts.get(cid, 0)}")
        for cid, n in counts.items():
            if n and cid not in stats.channel_message_counts:
                rep.add("statistics", self._name(cid), f"{n} message(s) not counted")

    def _check_records(self) -> None:
        """The rosbag2 record (metadata.yaml) and the package's counts record."""
        rep = self.report
        data = rep.by_topic()
        record = rep.metadata.get("rosbag2", {}).get("serialized_metadata")
        if record is not None:
            try:
                info = load_yaml(record)
            except yaml.YAMLError as exc:
                rep.add("rosbag2", "rosbag2 metadata record", f"not YAML ({exc})")
                info = None
            check_rosbag2_info(rep, info, data, {c.topic: c for c in rep.channels.values()},
                               "rosbag2 metadata record")
        counts_record = rep.metadata.get(COUNTS_RECORD)
        if counts_record is not None:
            try:
                counts = decode_counts(counts_record, rep.path)
            except BagError as exc:
                rep.add("counts", f"{COUNTS_RECORD} record", exc.problem)
                return
            for name, c in counts.items():
                have = data[name].count if name in data else 0
                if c["recorded"] != have:
                    rep.add("counts", f"topic {name}", f"the {COUNTS_RECORD} record says "
                            f"{c['recorded']} message(s) recorded, the data holds {have}")

    def _check_topics(self) -> None:
        rep = self.report
        own = CONFIG_RECORD in rep.metadata
        for t in rep.topics.values():
            if own and t.count:
                namespace = t.topic.split("/")[1] if t.topic.count("/") > 1 else ""
                try:
                    expected = message_type(t.topic, namespace)
                except BagError:
                    expected = None
                if expected is not None and expected != t.msg_type:
                    rep.add("schema", f"topic {t.topic}", f"declared as {t.msg_type!r}; the "
                            f"package's topic carries {expected}")
            first = {k: f"topic {t.topic}, first at t = {v * 1e-9:.6f} s"
                     for k, v in t.first_repeat_ns.items()}
            if t.conflicts and _sampled(t.topic):
                rep.add("duplicates", first["conflict"], f"{t.conflicts} sample time(s) carry "
                        "two different messages")
            allowed = int(RESENDS_ALLOWED * t.count) if _sampled(t.topic) else 0
            if t.duplicates > allowed:
                rep.add("duplicates", first["duplicate"], f"{t.duplicates} of {t.count} "
                        "messages repeat the message before them (same log time, same bytes)")
            if t.backwards and _sampled(t.topic):
                rep.add("order", first.get("backwards", f"topic {t.topic}"), f"log times go "
                        f"backwards {t.backwards} time(s) on a sampled topic")


def _sampled(topic: str) -> bool:
    return bool(SAMPLED.match(topic))
