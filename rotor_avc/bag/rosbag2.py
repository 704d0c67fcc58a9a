"""Bags as ``ros2 bag record`` writes them: a directory with ``metadata.yaml`` and split files.

:func:`open_bag` opens a ``.mcap`` file (:class:`~.reader.BagReader`) or a rosbag2 directory
(:class:`DirectoryBag`, same API: topics, message_count, time_range_ns, metadata, config, counts,
series, raw_messages, messages, log_times, chunk_log_times, codec, close, context manager). A
directory's ``metadata.yaml`` (``rosbag2_bagfile_information``, version 9 as Jazzy writes it)
lists its files in ``relative_file_paths``, in recording order; each file is opened and checked
by BagReader, and the directory reads as one bag over all of them. Only what reading needs is
checked here: the file exists and parses, the storage is ``mcap``, every listed file exists and
lies in the bag's folder (:func:`inside_bag`: nothing outside it is opened).
"""
from __future__ import annotations

import heapq
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import yaml

from .recording_reader import RecordingReader
from .errors import BagError
from .metadata import CONFIG_RECORD, load_yaml
from .reader import BagMessage, BagReader, TopicInfo, TopicSeries

METADATA_FILE = "metadata.yaml"


def open_bag(path, *, require_config: bool = False, require_messages: bool = False,
             integrity: bool = False) -> RecordingReader:
    """A reader for a ``.mcap`` file or a rosbag2 directory (see the module docstring;
    :class:`rotor_avc.bag.recording_reader.RecordingReader`);
    ``integrity``: every file first passes :func:`rotor_avc.bag.integrity.verify`."""
    path = Path(path)
    if path.is_dir():
        return DirectoryBag(path, require_config=require_config,
                            require_messages=require_messages, integrity=integrity)
    return BagReader(path, require_config=require_config, require_messages=require_messages,
                     integrity=integrity)


def bagfile_information(directory: Path) -> dict:
    """The ``rosbag2_bagfile_information`` mapping of a directory's ``metadata.yaml``
    (BagError naming what is missing or unreadable)."""
    meta_path = directory / METADATA_FILE
    if not meta_path.is_file():
        raise BagError(directory, f"a directory without {METADATA_FILE}: not a rosbag2 bag",
                       fix="give the bag directory `ros2 bag record` wrote, or a .mcap file")
    inside_bag(directory, METADATA_FILE, "the file")
    try:
        meta = load_yaml(meta_path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise BagError(meta_path, f"cannot read the file ({exc.strerror})",
                       fix="check its permissions") from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise BagError(meta_path, f"unreadable YAML ({str(exc).splitlines()[0]})",
                       fix="restore metadata.yaml (`ros2 bag reindex` rebuilds it)") from None
    info = meta.get("rosbag2_bagfile_information") if isinstance(meta, dict) else None
    if not isinstance(info, dict):
        raise BagError(meta_path, "no rosbag2_bagfile_information mapping",
                       fix="restore metadata.yaml (`ros2 bag reindex` rebuilds it)")
    return info


def inside_bag(directory: Path, name, where: str) -> Path:
    """``directory / name`` for a file name the bag lists (``where``: which entry), confined to
    the bag's folder: an absolute path, a ``..`` leading out or a symbolic link resolving outside
    is refused (BagError) before anything is opened, so a bag cannot make a reader open a file
    the user did not name."""
    meta_path = Path(directory) / METADATA_FILE
    fix = "list the bag's own files by their names in its folder (`ros2 bag reindex DIR`)"
    if not isinstance(name, str) or not name:
        raise BagError(meta_path, f"{where} is not a file name ({name!r})", fix=fix)
    if Path(name).is_absolute():
        raise BagError(meta_path, f"{where} {name!r} is an absolute path; a bag lists its "
                       "files relative to its folder", fix=fix)
    path = Path(directory) / name
    try:
        inside = path.resolve().is_relative_to(Path(directory).resolve())
    except (OSError, RuntimeError, ValueError):          # too long, a symlink loop, NUL
        inside = False
    if not inside:
        raise BagError(meta_path, f"{where} {name!r} leads outside the bag's folder (through "
                       "`..` or a symbolic link); it is not opened", fix=fix)
    return path


def listed_files(directory: Path, info: dict) -> list[Path]:
    """The files ``relative_file_paths`` lists, each confined to the bag's folder
    (:func:`inside_bag`), after checking that every ``files[i].path`` is confined too."""
    for i, entry in enumerate(info.get("files") or []):
        if isinstance(entry, dict) and "path" in entry:
            inside_bag(directory, entry["path"], f"files[{i}].path")
    return [inside_bag(directory, name, f"relative_file_paths[{i}]")
            for i, name in enumerate(info.get("relative_file_paths") or [])]


def bag_files(directory: Path) -> list[Path]:
    """The files a rosbag2 directory's ``metadata.yaml`` lists, in order (BagError naming what
    is missing or wrong)."""
    info = bagfile_information(directory)
    meta_path = directory / METADATA_FILE
    storage = info.get("storage_identifier")
    if storage != "mcap":
        raise BagError(meta_path, f"storage_identifier is {storage!r}; only mcap is read",
                       fix="record with `ros2 bag record -s mcap` or convert the bag "
                           "(`ros2 bag convert`)")
    names = info.get("relative_file_paths")
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise BagError(meta_path, "relative_file_paths must list the bag's files",
                       fix="restore metadata.yaml (`ros2 bag reindex` rebuilds it)")
    files = listed_files(directory, info)
    missing = [str(f.name) for f in files if not f.is_file()]
    if missing:
        raise BagError(directory, f"metadata.yaml lists {', '.join(missing)}, which is missing",
                       fix="copy the whole bag directory (every split file)")
    return files


class DirectoryBag:
    """A rosbag2 directory read as one bag over its split files (BagReader's API)."""

    def __init__(self, path, *, require_config: bool = False, require_messages: bool = False,
                 integrity: bool = False):
        self.path = Path(path)
        self._readers: list[BagReader] = []
        try:
            for f in bag_files(self.path):
                self._readers.append(BagReader(f, integrity=integrity))
            self.check(require_config=require_config, require_messages=require_messages)
        except BagError:
            self.close()
            raise

    # -- what is in it ---------------------------------------------------------------------
    @property
    def topics(self) -> dict[str, TopicInfo]:
        out: dict[str, TopicInfo] = {}
        for r in self._readers:
            for name, t in r.topics.items():
                if name in out:
                    seen = out[name]
                    if seen.msg_type != t.msg_type:
                        raise BagError(self.path, f"topic {name} is {seen.msg_type} in one file "
                                       f"and {t.msg_type} in {r.path.name}",
                                       fix="record one type per topic")
                    out[name] = TopicInfo(name, t.msg_type, seen.count + t.count,
                                          seen.type_hash or t.type_hash, seen.qos or t.qos)
                else:
                    out[name] = t
        return out

    @property
    def message_count(self) -> int:
        return sum(r.message_count for r in self._readers)

    @property
    def time_range_ns(self) -> tuple[int, int]:
        ranges = [r.time_range_ns for r in self._readers if r.message_count]
        if not ranges:
            return 0, 0
        return min(a for a, _ in ranges), max(b for _, b in ranges)

    @property
    def metadata(self) -> dict[str, dict[str, str]]:
        out: dict[str, dict[str, str]] = {}
        for r in self._readers:
            for name, record in r.metadata.items():
                out.setdefault(name, record)
        return out

    @property
    def config(self) -> dict[str, Any]:
        for r in self._readers:
            if CONFIG_RECORD in r.metadata:
                return r.config
        return self._readers[0].config               # raises the "no configuration" error

    @property
    def counts(self):
        return next((c for c in (r.counts for r in self._readers) if c is not None), None)

    #: the BagError a command needs: configuration present, messages present
    check = BagReader.check

    # -- messages --------------------------------------------------------------------------
    def _with(self, topic: str) -> list[BagReader]:
        if topic not in self.topics:
            raise BagError(self.path, f"no topic {topic}",
                           fix="use one of " + ", ".join(sorted(self.topics)))
        return [r for r in self._readers if topic in r.topics]

    def codec(self, topic: str):
        return self._with(topic)[0].codec(topic)

    def raw_messages(self, topics=None, start_ns=None, end_ns=None) -> Iterator[BagMessage]:
        names = [topics] if isinstance(topics, str) else topics
        for name in names or ():
            self._with(name)
        streams = [r.raw_messages([n for n in names if n in r.topics] if names else None,
                                  start_ns, end_ns)
                   for r in self._readers if not names or any(n in r.topics for n in names)]
        yield from heapq.merge(*streams, key=lambda m: m.time_ns)

    def messages(self, topics=None, start_ns=None, end_ns=None) -> Iterator[BagMessage]:
        for m in self.raw_messages(topics, start_ns, end_ns):
            data = self._with(m.topic)[0]._decode(m.topic, m.data)
            yield BagMessage(m.topic, m.time_ns, m.publish_time_ns, m.sequence, data)

    def series(self, topic: str) -> TopicSeries:
        parts = [r.series(topic) for r in self._with(topic) if r.topics[topic].count]
        if not parts:
            raise BagError(self.path, f"topic {topic} has no messages",
                           fix="check that the run published it")
        common = [k for k in parts[0].fields if all(k in p.fields for p in parts)]
        time_ns = np.concatenate([p.time_ns for p in parts])
        order = np.argsort(time_ns, kind="stable")
        fields = {k: np.concatenate([p.fields[k] for p in parts])[order] for k in common}
        return TopicSeries(topic, parts[0].msg_type, time_ns[order], fields, parts[0].labels)

    def series_chunks(self, topic: str) -> Iterator[TopicSeries]:
        """BagReader.series_chunks over every file, in the order of the chunks' first times."""
        streams = [r.series_chunks(topic) for r in self._with(topic) if r.topics[topic].count]
        if not streams:
            raise BagError(self.path, f"topic {topic} has no messages",
                           fix="check that the run published it")
        yield from heapq.merge(*streams, key=lambda part: int(part.time_ns[0]))

    def log_times(self, topic: str) -> np.ndarray:
        return np.sort(np.concatenate([r.log_times(topic) for r in self._with(topic)]))

    def chunk_log_times(self, topics) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        """BagReader.chunk_log_times over every file, in the order of the chunks' start times."""
        for name in topics:
            self._with(name)
        streams = [r.chunk_log_times([t for t in topics if t in r.topics])
                   for r in self._readers]
        yield from heapq.merge(*streams, key=lambda chunk: chunk[0])

    # -- closing ---------------------------------------------------------------------------
    def close(self) -> None:
        for r in self._readers:
            r.close()

    def __enter__(self) -> "DirectoryBag":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
