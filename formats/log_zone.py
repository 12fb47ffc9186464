"""What a log declares about itself in aion's metadata (``LogWriter.add_metadata``): the time
zone ``aion simulate --tz`` / ``aion convert --tz`` write (key ``timezone``) and the spans
``aion convert --observed`` declares (key ``observed``, :func:`spans_text`):

- an MCAP file: its ``aion`` metadata record, key ``timezone`` / ``observed``;
- a rosbag2 folder: ``custom_data`` ``aion.timezone`` / ``aion.observed`` in its
  ``metadata.yaml`` (the key-value map rosbag2 keeps for its writers' own data);
- a ROS 1 bag, which has no metadata record: one latched ``std_msgs/String`` message on
  ``/aion/timezone`` / ``/aion/observed`` at the log's first time (a topic of its own, as tools
  that store metadata inside bags do; ``rosbag play`` publishes it once, latched).

So ``aion build`` without ``--tz`` can take the zone the scene's hours follow, and warn when
``--tz`` names another (:mod:`aion_cli.log_zone`), and without ``--observed`` takes the spans
a converted log declares (:mod:`aion_cli.log_observed`).
"""

from __future__ import annotations

import contextlib
import struct
from collections.abc import Callable, Iterable, Sequence
from itertools import takewhile
from pathlib import Path

#: The metadata record and its key.
RECORD = "aion"
KEY = "timezone"
OBSERVED_KEY = "observed"
"""The key of the spans ``aion convert --observed`` declares (:func:`spans_text`)."""

STRING = "std_msgs/msg/String"
"""The type of a ROS 1 bag's metadata topics (:func:`metadata_topic`)."""


def metadata_topic(name: str, key: str) -> str:
    """The latched topic of a ROS 1 bag that holds metadata ``name``'s ``key``."""
    return f"/{name}/{key}"


def ros1_string(text: str) -> bytes:
    """A ``std_msgs/String`` in ROS 1 serialization: uint32 length, then UTF-8 bytes."""
    data = text.encode("utf-8")
    return struct.pack("<I", len(data)) + data


def _from_ros1_string(raw: bytes | memoryview) -> str | None:
    raw = bytes(raw)
    if len(raw) < 4:
        return None
    (n,) = struct.unpack_from("<I", raw)
    return raw[4 : 4 + n].decode("utf-8", errors="replace") if len(raw) == 4 + n else None


def spans_text(spans: Iterable[tuple[int, int]]) -> str:
    """Half-open spans ``[lo, hi)`` of log time (ns) as the metadata value: ``lo..hi`` joined
    by ``,`` (integers: exact, whatever zone they were given in)."""
    return ",".join(f"{int(a)}..{int(b)}" for a, b in spans)


def parse_spans_text(text: str) -> tuple[tuple[int, int], ...] | None:
    """The spans of :func:`spans_text`; None when ``text`` is not such a list (a value some
    other writer left: as if the log declared none)."""
    out = []
    for part in text.split(","):
        lo, sep, hi = part.strip().partition("..")
        try:
            a, b = int(lo), int(hi)
        except ValueError:
            return None
        if not sep or not 0 <= a < b:
            return None
        out.append((a, b))
    return tuple(out) or None


def declared_zones(paths: Sequence[Path]) -> dict[str, str]:
    """Per log among ``paths`` (by its path text), the zone it declares (see the module
    docstring); logs without one and logs that cannot be read are left out (the build reads
    them and says what is wrong)."""
    return declared_values(paths, KEY)


def declared_spans(paths: Sequence[Path]) -> dict[str, tuple[tuple[int, int], ...]]:
    """Per log among ``paths`` (by its path text), the observed spans it declares (``aion
    convert --observed``: :func:`spans_text`); logs without them, with a value that is not
    such a list, or that cannot be read are left out."""
    out = {}
    for path, text in declared_values(paths, OBSERVED_KEY).items():
        spans = parse_spans_text(text)
        if spans is not None:
            out[path] = spans
    return out


def declared_values(paths: Sequence[Path], key: str) -> dict[str, str]:
    """Per log among ``paths`` (by its path text), the value of its aion metadata ``key``;
    logs without one and logs that cannot be read are left out."""
    out: dict[str, str] = {}
    for path in paths:
        value = declared(path).get(key)
        if value:
            out[str(path)] = value
    return out


def declared(path: Path) -> dict[str, str]:
    """All the aion metadata a log declares (key: value; empty when it declares none or
    cannot be read: the build reads it and says why). Read once per state of the file read
    (its device, inode, size and modification time): a build asks for the zone and for the
    spans, and a ROS 1 bag's index is read to answer either."""
    from aion_cli.formats.log_format import guess_format

    try:
        kind, target = guess_format(path)
        read = _READERS.get(kind)
        if read is None:
            return {}
        source = _source(kind, target)
        stat = source.stat()
        identity = (str(source), stat.st_dev, stat.st_ino, stat.st_size, stat.st_mtime_ns)
        if identity not in _SEEN:
            if len(_SEEN) >= _SEEN_MAX:
                _SEEN.pop(next(iter(_SEEN)))
            _SEEN[identity] = read(target)
        return dict(_SEEN[identity])
    except Exception:  # a damaged log declares nothing: the build reads it and says why
        return {}


_SEEN: dict[tuple[str, int, int, int, int], dict[str, str]] = {}
_SEEN_MAX = 256


def _source(kind: str, target: Path) -> Path:
    """The file whose bytes hold ``target``'s metadata: a rosbag2 folder's metadata.yaml."""
    if kind == "rosbag2":
        return (target if target.is_dir() else target.parent) / "metadata.yaml"
    return target


def _mcap_metadata(path: Path) -> dict[str, str]:
    """The keys of an MCAP file's ``aion`` metadata records from its metadata index (its
    summary; a later record's non-empty value wins); in a file without one (a recorder
    stopped before the summary) only the records before its first chunk or message are read,
    where aion's writers put the record (:meth:`LogWriter.add_metadata` is called before the
    first message): mcap's own fallback reads, and decompresses, the whole file before the
    build reads it again, and loses the zone at a damaged record."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader
    from mcap.records import Chunk, DataEnd, Message, Metadata
    from mcap.stream_reader import StreamReader

    if not path.is_file():
        return {}
    found: dict[str, str] = {}
    with path.open("rb") as f:
        reader = make_reader(f)
        try:
            summary = reader.get_summary()
        except (McapError, ValueError, struct.error):  # a file cut short: no footer
            summary = None
        if summary is not None:
            records: Iterable[object] = reader.iter_metadata()
        else:
            f.seek(0)
            records = takewhile(
                lambda r: not isinstance(r, (Chunk, Message, DataEnd)),
                StreamReader(f, emit_chunks=True).records,
            )
        with contextlib.suppress(McapError):  # a record cut short ends the search there
            for record in records:
                if isinstance(record, Metadata) and record.name == RECORD:
                    found.update((k, v) for k, v in record.metadata.items() if v)
    return found


def _bag_metadata(path: Path) -> dict[str, str]:
    """The ``/aion/KEY`` topics of a ROS 1 bag (:func:`metadata_topic`): each one's first
    ``std_msgs/String`` message."""
    from rosbags.rosbag1 import Reader

    prefix = metadata_topic(RECORD, "")
    found: dict[str, str] = {}
    with Reader(path) as reader:
        ours = [
            c for c in reader.connections
            if c.topic.startswith(prefix) and c.msgtype == STRING
        ]  # fmt: skip
        if not ours:
            return found  # (no connections given, rosbags reads every message)
        for connection, _, raw in reader.messages(connections=ours):
            # the first message of each topic, as written (an empty one declares nothing)
            found.setdefault(connection.topic[len(prefix) :], _from_ros1_string(raw) or "")
    return {key: text for key, text in found.items() if text}


def _rosbag2_metadata(path: Path) -> dict[str, str]:
    """The ``aion.KEY`` entries of a rosbag2 folder's ``custom_data``."""
    from ruamel.yaml import YAML  # rosbags' own YAML library

    from aion_cli.formats.log_target import _MAX_METADATA_BYTES

    meta = _source("rosbag2", path)
    if not meta.is_file() or meta.stat().st_size > _MAX_METADATA_BYTES:
        return {}
    doc = YAML(typ="safe").load(meta.read_text(encoding="utf-8"))
    custom = doc["rosbag2_bagfile_information"].get("custom_data") or {}
    prefix = f"{RECORD}."
    return {
        k[len(prefix) :]: v for k, v in custom.items()
        if isinstance(k, str) and k.startswith(prefix) and isinstance(v, str)
    }  # fmt: skip


_READERS: dict[str, Callable[[Path], dict[str, str]]] = {
    "mcap": _mcap_metadata,
    "bag": _bag_metadata,
    "rosbag2": _rosbag2_metadata,
}
