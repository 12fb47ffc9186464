"""A file read as a log whose first bytes are not its container's: :func:`not_a_log` says so,
names what the file looks like when that is cheap to tell (another log, an aion map, a scene
graph, a tracks file, text or CSV, a zip or gzip archive; :func:`looks_like`), and the readers
raise it as :class:`NotALogError` (a ``printf 'hello\\n' > x.bag`` suggested `rosbag reindex`,
as a damaged bag does).
"""

from __future__ import annotations

from pathlib import Path

from aion_cli.errors import AionError, LogFormatError

#: what a ROS 1 bag starts with (format 2.0, the only one rosbags reads)
BAG_MAGIC = b"#ROSBAG V2.0\n"
_OLD_BAG = b"#ROSBAG V"
_HEAD_BYTES = 4096
_SHOWN_CHARS = 40


class NotALogError(LogFormatError):
    """A file does not start with the magic bytes of the container it is read as."""


def looks_like(path: Path) -> str | None:
    """What ``path`` looks like from its first bytes, or None (binary data of no kind aion
    knows, or unreadable). Reads at most a few KiB."""
    from aion_cli.formats import rosbag2_storage as storage
    from aion_cli.formats.input_kind import input_kind
    from aion_cli.formats.log_format import other_log_name
    from aion_cli.formats.track_sniff import guess_layout

    try:
        with path.open("rb") as f:
            head = f.read(_HEAD_BYTES)
        kind = storage.sniff(path)
    except (OSError, AionError):  # damaged zstd data
        return None
    if kind is not None:
        return other_log_name(kind)
    if head.startswith(_OLD_BAG):
        version = head[len(_OLD_BAG) :].split(b"\n", 1)[0].decode("ascii", "replace")
        return f"a ROS bag of format {version!r} (aion reads format 2.0)"
    if head.startswith(storage.ZSTD_MAGIC):
        return "zstd-compressed data of no log aion reads"
    found = input_kind(path)
    if found == "map":
        return "an aion map"
    if found == "graph":
        return "a scene-graph file"
    guess = guess_layout(path)
    if guess is not None:
        return f"a tracks file in {guess.describe()}"
    if head.startswith(b"PK\x03\x04"):
        return "a zip archive without an aion map manifest"
    if head.startswith(b"\x1f\x8b"):
        return "gzip-compressed data"
    return _text(head)


def _text(head: bytes) -> str | None:
    """``text starting 'hello'`` or ``CSV text starting 'a,b,c'`` for UTF-8 text without NUL
    bytes (a character cut at the end of ``head`` allowed); None for binary data."""
    if b"\x00" in head:
        return None
    text = head.decode("utf-8", errors="replace")
    if "\ufffd" in text[:-1]:
        return None
    lines = [line for line in text.splitlines() if line.strip()]
    if not lines:
        return "blank text"
    first = lines[0].strip()
    commas = first.count(",")
    csv = commas > 0 and len(lines) > 1 and lines[1].count(",") == commas
    shown = first[:_SHOWN_CHARS] + ("..." if len(first) > _SHOWN_CHARS else "")
    return f"{'CSV text' if csv else 'text'} starting {shown!r}"


def not_a_log(path: Path, what: str, magic: str, hint: str) -> NotALogError:
    """The error for ``path`` read as ``what`` (``"a ROS 1 bag"``) without its ``magic``
    (``"'#ROSBAG V2.0'"``): what it looks like, and ``hint`` unless the file is another input
    aion reads (a map, a scene graph, a tracks file: where it goes instead)."""
    from aion_cli.formats.log_format import _what_else

    seen = looks_like(path)
    return NotALogError(
        f"{path} is not {what} (it does not start with {magic})"
        + (f": it looks like {seen}" if seen else ""),
        hint=_what_else(path) or hint,
    )


def check_bag_magic(path: Path) -> None:
    """:class:`NotALogError` unless ``path`` starts as a ROS 1 bag (format 2.0) does."""
    try:
        with path.open("rb") as f:
            head = f.read(len(BAG_MAGIC))
    except OSError:
        return  # the reader says why it cannot open it
    if head != BAG_MAGIC:
        raise not_a_log(
            path,
            "a ROS 1 bag",
            repr(BAG_MAGIC.decode().strip()),
            "check the file, or pass --log-format mcap|rosbag2 if it is another log type",
        )
