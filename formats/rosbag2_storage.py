"""rosbag2 storage files on their own: finding them, telling what they hold, decompressing them.

A rosbag2 bag is a folder with ``metadata.yaml`` and storage files (``*.db3`` for sqlite3,
``*.mcap`` for mcap), compressed whole with zstd (``*.db3.zstd``, ``*.mcap.zstd``) when the bag
was recorded with ``compression_mode: file``. A recording killed before it finished, or a bag
whose ``metadata.yaml`` was lost, leaves the storage files only: ``ros2 bag reindex`` rebuilds
the metadata from them, and :mod:`formats.rosbag2_reindex` does the same in memory.

This module holds what that needs below the readers: the storage files of a folder in their
recording order (:func:`storage_files`), the kind of a file from its first bytes, through zstd
too (:func:`sniff`), streaming decompression of a zstd-compressed file into a temporary
folder (:func:`decompress_to_temp`: bounded memory, the folder removed by the caller, or here
when decompression fails), and the figures ``metadata.yaml`` states (:func:`metadata_figures`)
with what in them disagrees with the storage files (:func:`metadata_disagreements`): aion takes
counts and times from the storage files, and says when metadata.yaml states others.
"""

from __future__ import annotations

import re
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from aion_cli.engine.time_text import iso_utc
from aion_cli.errors import LogFormatError
from aion_cli.listing import first_few

ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
MCAP_MAGIC = b"\x89MCAP0\r\n"
BAG_MAGIC = b"#ROSBAG V2.0"
SQLITE_MAGIC = b"SQLite format 3\x00"

#: suffixes of the storage files rosbag2 writes (before any compression suffix)
STORAGE_SUFFIXES = (".db3", ".mcap")
#: suffixes of a file compressed whole with zstd
ZSTD_SUFFIXES = (".zstd", ".zst")

#: compressed bytes decompressed at a time: what one step can expand to stays small (zstd's
#: worst case is about 32,000 times its input, real storage files a few times)
_PIECE = 16 << 10
_DIGITS = re.compile(r"(\d+)")


def is_zstd(path: Path) -> bool:
    """Whether ``path`` is a zstd-compressed file: by its suffix, else by its magic bytes."""
    if path.suffix.lower() in ZSTD_SUFFIXES:
        return True
    try:
        with path.open("rb") as f:
            return f.read(4) == ZSTD_MAGIC
    except OSError:
        return False


def inner_name(path: Path) -> str:
    """The name of the file a zstd-compressed ``path`` holds (``bag_0.mcap.zstd`` ->
    ``bag_0.mcap``)."""
    if path.suffix.lower() in ZSTD_SUFFIXES:
        return path.stem
    return path.name


def _natural_key(path: Path) -> list[object]:
    """``bag_2.db3`` before ``bag_10.db3``: rosbag2 numbers split files without padding."""
    return [int(part) if part.isdigit() else part for part in _DIGITS.split(path.name)]


def storage_files(folder: Path) -> list[Path]:
    """The rosbag2 storage files of ``folder`` (plain or zstd-compressed), in recording order
    (their split index), or [] when it has none."""
    found = []
    for p in folder.iterdir():
        if not p.is_file():
            continue
        suffix = Path(inner_name(p)).suffix.lower()
        if suffix in STORAGE_SUFFIXES:
            found.append(p)
    return sorted(found, key=_natural_key)


def kind_of(head: bytes) -> str | None:
    if head.startswith(MCAP_MAGIC):
        return "mcap"
    if head.startswith(BAG_MAGIC):
        return "bag"
    if head.startswith(SQLITE_MAGIC):
        return "sqlite3"
    return None


def sniff(path: Path) -> str | None:
    """What ``path`` holds, from its first bytes (decompressed first when it is zstd):
    ``"mcap"``, ``"bag"``, ``"sqlite3"``, or None when it is none of them (or unreadable).
    Raises :class:`LogFormatError` for zstd data that is damaged or ends before 16 bytes."""
    import zstandard

    try:
        with path.open("rb") as f:
            head = f.read(16)
            if not head.startswith(ZSTD_MAGIC):
                return kind_of(head)
            f.seek(0)
            obj = zstandard.ZstdDecompressor().decompressobj()
            inner = b""
            while len(inner) < 16 and not obj.eof and (piece := f.read(_PIECE)):
                inner += obj.decompress(piece)
    except OSError:
        return None
    except zstandard.ZstdError as exc:
        raise _damaged(path, exc) from exc
    if len(inner) < 16 and not obj.eof:
        raise _damaged(path, "the data ends inside a zstd frame (truncated file)")
    return kind_of(inner)


def _damaged(path: Path, why: object) -> LogFormatError:
    return LogFormatError(
        f"{path}: not a readable zstd file ({why})",
        hint="the compressed storage file may be truncated or corrupt",
    )


def decompress_to_temp(path: Path) -> tuple[tempfile.TemporaryDirectory[str], Path]:
    """Decompress the zstd file ``path`` into a new temporary folder, streaming (a small
    piece at a time, whatever the file's size): ``(folder, decompressed file)``; the file
    keeps the inner name (``bag_0.mcap.zstd`` -> ``bag_0.mcap``) so messages about it read
    naturally. A file that ends inside a zstd frame is refused, not read as far as it goes.

    The caller owns the folder and calls its ``cleanup()`` when done. Raises
    :class:`LogFormatError` (the folder removed) when the data is not zstd or is damaged, or
    when the temporary disk runs out.
    """
    import zstandard

    try:
        tmp = tempfile.TemporaryDirectory(prefix="aion-unzstd-")
    except OSError as exc:
        raise _no_room(path, exc) from exc
    target = Path(tmp.name) / inner_name(path)
    try:
        src = path.open("rb")
    except OSError as exc:
        tmp.cleanup()
        raise LogFormatError(f"{path}: cannot read it ({exc.strerror or exc})") from exc
    try:
        with src, target.open("wb") as dst:
            _unzstd_stream(src, dst)
    except zstandard.ZstdError as exc:
        tmp.cleanup()
        raise _damaged(path, exc) from exc
    except OSError as exc:
        tmp.cleanup()
        raise _no_room(path, exc) from exc
    return tmp, target


def name_original(error: BaseException, original: Path, inner: Path) -> None:
    """``error`` (an :class:`~aion_cli.errors.AionError` raised reading ``inner``, the
    decompressed temporary copy :func:`decompress_to_temp` made of ``original``) made to name
    the user's file, ``original (decompressed)``, wherever it named the copy, which is gone
    by the time the user reads the error. Changed in place (its type and fields are kept)."""
    from aion_cli.errors import AionError

    if not isinstance(error, AionError):
        return
    error.message = shown_text(error.message, original, inner)
    if error.hint is not None:
        error.hint = shown_text(error.hint, original, inner)
    error.args = tuple(
        shown_text(a, original, inner) if isinstance(a, str) else a for a in error.args
    )


DECOMPRESSED = " of the decompressed data"
"""Follows a byte offset in a message about a compressed log: the readers count in the
decompressed copy, which no tool shows the user at that offset in the file on disk."""

_OFFSET = re.compile(r"\bbyte (\d[\d,]*)(?![\d,])(?: of (\d[\d,]*)(?![\d,]))?")
"""A byte offset in a reader's message: ``at byte 73``, ``ends at byte 1,000 of 2,000``."""


def shown_text(text: str, original: Path, inner: Path) -> str:
    """``text`` (an error or a warning about ``inner``, the decompressed temporary copy of
    ``original``) naming the user's file instead: the copy's path as ``original
    (decompressed)``, and a line that starts with the copy's name (``t.mcap: truncated ...``,
    how the readers' warnings name their file) starting with the original's (``t.mcap.zst:``).
    Its byte offsets count in the copy, so each says so: ``at byte 73 of the decompressed
    data``, ``at byte 1,000 of the decompressed data's 2,000`` (once: a text shown already
    is left as it is)."""
    text = text.replace(str(inner), f"{original} (decompressed)")
    if text.startswith(f"{inner.name}:"):
        text = original.name + text[len(inner.name) :]
    if DECOMPRESSED not in text and "decompressed data's" not in text:
        text = _OFFSET.sub(_decompressed_offset, text)
    return text


def _decompressed_offset(found: re.Match[str]) -> str:
    at, size = found.group(1), found.group(2)
    if size is None:
        return f"byte {at}{DECOMPRESSED}"
    return f"byte {at}{DECOMPRESSED}'s {size}"


def _unzstd_stream(src: IO[bytes], dst: IO[bytes]) -> None:
    """Decompress the zstd frames of ``src`` into ``dst``, a small piece of input at a time (the
    output of a piece is written before the next is read), across frames (streaming writers
    write many). Raises ``ZstdError`` for damaged data and for input that ends inside a frame,
    which zstandard's stream readers would take silently as the end."""
    import zstandard

    dctx = zstandard.ZstdDecompressor()
    obj = dctx.decompressobj()
    started = False  # the current frame has received input
    while piece := src.read(_PIECE):
        while piece:
            started = True
            dst.write(obj.decompress(piece))
            if not obj.eof:
                break
            piece = obj.unused_data  # the next frame begins in this piece
            obj = dctx.decompressobj()
            started = False
    if started and not obj.eof:
        raise zstandard.ZstdError("the data ends inside a zstd frame (truncated file)")


def _no_room(path: Path, exc: OSError) -> LogFormatError:
    return LogFormatError(
        f"{path}: cannot decompress it into {tempfile.gettempdir()} ({exc.strerror or exc})",
        hint="free disk space there, or set TMPDIR to a folder with room for the "
        "decompressed file",
    )


# -- metadata.yaml against the storage files ---------------------------------------------------


@dataclass(frozen=True)
class MetadataFigures:
    """The figures a bag's ``metadata.yaml`` states (None where it states none, or a value
    that is not an integer): first message time, duration (last minus first), message count,
    counts per (topic, type as written)."""

    start_ns: int | None
    duration_ns: int | None
    message_count: int | None
    topic_counts: dict[tuple[str, str], int] = field(default_factory=dict)


def _integer(value: object) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def _nested(mapping: object, *keys: str) -> object:
    for key in keys:
        if not isinstance(mapping, dict):
            return None
        mapping = mapping.get(key)
    return mapping


def _bagfile_information(folder: Path) -> dict[Any, Any] | None:
    """``rosbag2_bagfile_information`` of ``folder/metadata.yaml``, or None when the file
    cannot be read as YAML or holds no such mapping (the reader says why elsewhere)."""
    from ruamel.yaml import YAML

    try:
        data = YAML(typ="safe").load((folder / "metadata.yaml").read_text(encoding="utf-8"))
    except Exception:  # OSError, YAML and decoding errors: the reader says why elsewhere
        return None
    info = _nested(data, "rosbag2_bagfile_information")
    return info if isinstance(info, dict) else None


def metadata_figures(folder: Path) -> MetadataFigures | None:
    """What ``folder/metadata.yaml`` states, or None when it cannot be read as YAML."""
    info = _bagfile_information(folder)
    if info is None:
        return None
    counts: dict[tuple[str, str], int] = {}
    for entry in info.get("topics_with_message_count") or []:
        name = _nested(entry, "topic_metadata", "name")
        msgtype = _nested(entry, "topic_metadata", "type")
        count = _integer(_nested(entry, "message_count"))
        if isinstance(name, str) and isinstance(msgtype, str) and count is not None:
            counts[name, msgtype] = counts.get((name, msgtype), 0) + count
    return MetadataFigures(
        _integer(_nested(info, "starting_time", "nanoseconds_since_epoch")),
        _integer(_nested(info, "duration", "nanoseconds")),
        _integer(info.get("message_count")),
        counts,
    )


def metadata_type_error(folder: Path) -> str | None:
    """What in ``folder/metadata.yaml`` is not of its type: a message count (of the bag or of
    a topic), the start time or the duration that is no integer, a topic name or type that is
    no string. rosbags takes any YAML value there, and a sum over the counts failed later
    (``int += str``). None when all are, or the yaml cannot be read (rosbags says why)."""
    info = _bagfile_information(folder)
    if info is None:
        return None
    values: list[tuple[str, object, type]] = [
        ("message_count", info.get("message_count"), int),
        ("starting_time", _nested(info, "starting_time", "nanoseconds_since_epoch"), int),
        ("duration", _nested(info, "duration", "nanoseconds"), int),
    ]
    entries = info.get("topics_with_message_count")
    for entry in entries if isinstance(entries, list) else []:
        name = _nested(entry, "topic_metadata", "name")
        values += [
            ("a topic's name", name, str),
            (f"the topic type of {name}", _nested(entry, "topic_metadata", "type"), str),
            (f"the message_count of {name}", _nested(entry, "message_count"), int),
        ]
    for what, value, kind in values:
        if value is not None and (not isinstance(value, kind) or isinstance(value, bool)):
            wanted = "an integer" if kind is int else "text"
            return f"metadata.yaml: {what} is {value!r}, not {wanted}"
    return None


def unlisted_storage_files(folder: Path) -> list[str]:
    """The names of the storage files in ``folder`` that its metadata.yaml does not list (a
    split written after the yaml, another bag's file copied in): a reader of the yaml leaves
    them out. [] when the yaml lists no files or cannot be read (the reader says why)."""
    from ruamel.yaml import YAML

    try:
        data = YAML(typ="safe").load((folder / "metadata.yaml").read_text(encoding="utf-8"))
    except Exception:  # OSError, YAML and decoding errors: the reader says why elsewhere
        return []
    listed = _nested(data, "rosbag2_bagfile_information", "relative_file_paths")
    if not isinstance(listed, list) or not listed:
        return []
    names = {Path(str(name)).name for name in listed}
    return [p.name for p in storage_files(folder) if p.name not in names]


def uncompressed_files_note(folder: Path) -> str | None:
    """What is wrong when ``folder/metadata.yaml`` says the bag was recorded with
    ``compression_mode: file`` but some storage files it lists are not zstd-compressed (a
    recording killed before its last file was compressed, a file decompressed by hand):
    rosbags then fails with zstd's own words, naming no file. None when every listed file is
    compressed, the yaml says no file compression or cannot be read, or ``folder`` is not a
    folder."""
    from ruamel.yaml import YAML

    from aion_cli.listing import first_few

    if not folder.is_dir():
        return None
    try:
        data = YAML(typ="safe").load((folder / "metadata.yaml").read_text(encoding="utf-8"))
    except Exception:  # OSError, YAML and decoding errors: the reader says why elsewhere
        return None
    info = _nested(data, "rosbag2_bagfile_information")
    if not isinstance(info, dict) or str(info.get("compression_mode") or "").lower() != "file":
        return None
    listed = info.get("relative_file_paths")
    names = [Path(str(name)).name for name in listed] if isinstance(listed, list) else []
    plain = [n for n in names if (folder / n).is_file() and not is_zstd(folder / n)]
    if not plain:
        return None
    verb = "is" if len(plain) == 1 else "are"
    return (
        f"its metadata.yaml says compression_mode: file, but {first_few(plain, 3)} {verb} not "
        "zstd-compressed"
    )


def metadata_disagreements(
    figures: MetadataFigures,
    start_ns: int,
    last_ns: int,
    total: int,
    counts: Mapping[tuple[str, str], int],
    normalize: Any = None,
) -> list[str]:
    """What ``figures`` state that the storage files contradict (first message at
    ``start_ns``, last at ``last_ns``, ``total`` messages, ``counts`` per (topic, normalised
    type); ``normalize`` maps metadata type names to normalised ones), one phrase each;
    impossible values (negative times, durations or counts) are called so."""
    out = []
    start, duration, count = figures.start_ns, figures.duration_ns, figures.message_count
    if start is not None and total and start != start_ns:
        what = "impossible: before 1970" if start < 0 else iso_utc(start)
        out.append(f"starting_time {start} ns ({what}; the files start at {iso_utc(start_ns)})")
    if duration is not None and total and duration != last_ns - start_ns:
        what = "impossible, " if duration < 0 else ""
        out.append(f"duration {duration} ns ({what}the files: {last_ns - start_ns} ns)")
    if count is not None and count != total:
        what = "impossible, " if count < 0 else ""
        out.append(f"message_count {count} ({what}the files: {total})")
    for (topic, msgtype), n in sorted(figures.topic_counts.items()):
        key = (topic, normalize(msgtype) if normalize is not None else msgtype)
        if key in counts and counts[key] != n:
            out.append(f"{n} messages on {topic} (the files: {counts[key]})")
        kept = sorted(t for name, t in counts if name == topic and t != key[1])
        if key not in counts and kept:
            out.append(f"{topic} is of type {msgtype} (the files: {', '.join(kept)})")
    return out


def metadata_warning(
    folder: Path, start: int, last: int, total: int, counts: Mapping[tuple[str, str], int]
) -> str | None:
    """A warning when the folder's metadata.yaml states figures its storage files contradict
    (aion uses the storage files: first and last message time ``start`` / ``last``, ``total``
    messages, ``counts`` per (topic, normalised type)); None when they agree."""
    from aion_cli.formats.raw import normalize_msgtype

    figures = metadata_figures(folder)
    if figures is None:
        return None
    found = metadata_disagreements(figures, start, last, total, counts, normalize_msgtype)
    if not found:
        return None
    return (
        f"{folder.name}: metadata.yaml disagrees with its storage files, which aion uses "
        f"instead: {first_few(found, 4, '; ')}"
    )
