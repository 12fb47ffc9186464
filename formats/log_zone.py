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
    from aion_cli.formats.log_format import guess_format

    out: dict[str, str] = {}
    for path in paths:
        try:
            kind, target = guess_format(path)
            value = _reader(kind)(target, key)
        except Exception:  # a damaged log declares nothing: the build reads it and says why
            continue
        if isinstance(value, str) and value:
            out[str(path)] = value
    return out


def _reader(kind: str) -> Callable[[Path, str], str | None]:
    return {"mcap": _mcap_zone, "bag": _bag_zone, "rosbag2": _rosbag2_zone}.get(kind, _none)


def _none(_path: Path, _key: str) -> None:
    return None


def _mcap_zone(path: Path, key: str = KEY) -> str | None:
    """The zone of an MCAP file's metadata index (its summary); in a file without one (a
    recorder stopped before the summary) only the records before its first chunk or
    message are read, where aion's writers put the record (:meth:`LogWriter.add_metadata`
    is called before the first message): mcap's own fallback reads, and decompresses, the
    whole file before the build reads it again, and loses the zone at a damaged record."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader
    from mcap.records import Chunk, DataEnd, Message, Metadata
    from mcap.stream_reader import StreamReader

    if not path.is_file():
        return None
    zone = None
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
                if (
                    isinstance(record, Metadata)
                    and record.name == RECORD
                    and record.metadata.get(key)
                ):
                    zone = record.metadata[key]
    return zone


def _bag_zone(path: Path, key: str = KEY) -> str | None:
    from rosbags.rosbag1 import Reader

    topic = metadata_topic(RECORD, key)
    with Reader(path) as reader:
        found = [
            c for c in reader.connections
            if c.topic == topic and c.msgtype == STRING
        ]  # fmt: skip
        if not found:
            return None  # (no connections given, rosbags reads every message)
        for _, _, raw in reader.messages(connections=found):
            return _from_ros1_string(raw)
    return None


def _rosbag2_zone(path: Path, key: str = KEY) -> str | None:
    from ruamel.yaml import YAML  # rosbags' own YAML library

    from aion_cli.formats.log_target import _MAX_METADATA_BYTES

    folder = path if path.is_dir() else path.parent
    meta = folder / "metadata.yaml"
    if not meta.is_file() or meta.stat().st_size > _MAX_METADATA_BYTES:
        return None
    doc = YAML(typ="safe").load(meta.read_text(encoding="utf-8"))
    custom = doc["rosbag2_bagfile_information"].get("custom_data") or {}
    zone = custom.get(f"{RECORD}.{key}")
    return zone if isinstance(zone, str) else None
