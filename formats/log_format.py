"""Which container a log path holds: :func:`guess_format` (``.mcap`` / ``.bag`` files, rosbag2
folders or their files, rosbag2 storage files without metadata.yaml, zstd-compressed storage
files; otherwise the first bytes decide, :func:`formats.rosbag2_storage.sniff`) and the values
``--log-format`` accepts instead (:data:`FORMATS`). Special files are refused before any read.
"""

from __future__ import annotations

import re
from pathlib import Path

from aion_cli.errors import LogFormatError, path_word
from aion_cli.formats.raw import check_regular_input
from aion_cli.listing import first_few

FORMATS: tuple[str, ...] = ("mcap", "bag", "rosbag2")
"""Values of ``fmt`` / ``--format``."""

#: the log files aion reads by their names' suffix, and the container each names; a name may
#: also end in a zstd suffix (``rosbag2_storage.ZSTD_SUFFIXES``: ``run.bag.zst`` is a ROS 1 bag
#: compressed whole), which :func:`log_suffix` looks through
LOG_SUFFIXES: dict[str, str] = {".mcap": "mcap", ".bag": "bag", ".db3": "rosbag2"}

_LOG_HINT = "pass a log file (.mcap, .bag) or a rosbag2 folder"

_BAG_MAGIC = b"#ROSBAG V2.0"
_SQLITE_MAGIC = b"SQLite format 3\x00"


def log_suffix(path: Path) -> str:
    """The suffix of the log ``path`` names, through a zstd suffix (``run.bag.zst`` ->
    ``.bag``), lower case: a key of :data:`LOG_SUFFIXES` when it names a log."""
    from aion_cli.formats.rosbag2_storage import inner_name

    return Path(inner_name(path)).suffix.lower()


def guess_format(path: Path) -> tuple[str, Path]:
    """``(format, path to open)`` for ``path``: ``.mcap`` / ``.bag`` files, rosbag2 folders
    (or their ``metadata.yaml`` / storage files), rosbag2 storage files without
    ``metadata.yaml`` (a folder of them, or one ``.db3``), zstd-compressed storage files
    (``*.mcap.zstd``, ``*.db3.zstd``, read through a decompressed temporary copy); otherwise
    the file's first bytes decide (through zstd too)."""
    from aion_cli.formats import rosbag2_storage as storage
    from aion_cli.formats.input_kind import bare_zip

    check_regular_input(path, "log", hint=_LOG_HINT)  # a FIFO or /dev/zero: before any read
    if not path.exists():
        raise LogFormatError(f"no such file or folder: {path}", hint="check the log path")
    if path.is_dir():
        for entry in path.iterdir():  # what a rosbag2 reader would open
            if entry.name == "metadata.yaml" or log_suffix(entry) in storage.STORAGE_SUFFIXES:
                check_regular_input(entry, "log", hint=_LOG_HINT)
        if (path / "metadata.yaml").is_file():
            return "rosbag2", path
        if storage.storage_files(path):
            _refuse_other_logs(path)
            _refuse_folder_of_logs(path)
            return "rosbag2", path
        found = sorted(p.name for p in path.iterdir())[:5]
        raise LogFormatError(
            f"{path} is a folder but not a rosbag2 bag (no metadata.yaml, no storage files)",
            hint="pass a .mcap or .bag file, or a rosbag2 folder; the folder holds: "
            + (", ".join(found) if found else "nothing"),
        )
    if path.stat().st_size == 0:
        raise LogFormatError(f"{path} is empty (0 bytes)", hint="the recording was not written")
    compressed = storage.is_zstd(path)
    suffix = log_suffix(path)
    beside_metadata = (path.parent / "metadata.yaml").is_file()
    if path.name == "metadata.yaml" or (
        beside_metadata and (suffix == ".db3" or (compressed and suffix == ".mcap"))
    ):
        return "rosbag2", path.parent
    if not compressed and suffix in LOG_SUFFIXES:
        return LOG_SUFFIXES[suffix], path  # one .db3 alone: reindexed
    kind = storage.sniff(path)
    if kind == "mcap":
        return ("rosbag2" if compressed else "mcap"), path
    if kind == "bag":
        return "bag", path
    if kind == "sqlite3":
        return "rosbag2", path
    if compressed:
        raise LogFormatError(
            f"{path} is zstd-compressed but holds no log aion reads",
            hint="aion reads zstd-compressed rosbag2 storage files (.mcap.zstd, .db3.zstd)",
        )
    hint = _what_else(path)  # the ground truth `aion simulate` writes is a zip (.npz) too
    bare = bare_zip(path) if hint is None else None
    if bare is not None:
        raise LogFormatError(*bare)
    raise LogFormatError(
        f"cannot tell the log format of {path}",
        hint=hint
        or "aion reads .mcap, ROS 1 .bag and rosbag2 folders; use --log-format mcap|bag|rosbag2",
    )


#: what a log of each kind (:func:`formats.rosbag2_storage.sniff`) is, and the ``--log-format``
#: that reads it
_CONTENTS = {
    "mcap": ("an MCAP file", "mcap"),
    "bag": ("a ROS 1 bag", "bag"),
    "sqlite3": ("an SQLite database, a rosbag2 storage file", "rosbag2"),
}


def other_log(path: Path, wanted: str) -> tuple[str, str] | None:
    """``(what it is, --log-format that reads it)`` when ``path``, to be read as ``wanted``
    (``"mcap"`` or ``"bag"``), is another kind of log: a folder (a rosbag2 bag) or a file whose
    first bytes are another container's; None when it may be ``wanted`` or is no log aion
    knows (the reader then says why it cannot read it)."""
    from aion_cli.formats import rosbag2_storage as storage

    if path.is_dir():
        return "a rosbag2 bag folder", "rosbag2"
    kind = storage.sniff(path)
    if kind is None or _CONTENTS[kind][1] == wanted:
        return None
    return _CONTENTS[kind]


def other_log_name(kind: str) -> str:
    """What a log of ``kind`` (:func:`formats.rosbag2_storage.sniff`) is: ``an MCAP file``."""
    return _CONTENTS[kind][0]


def other_log_hint(fmt: str) -> str:
    """The hint for a log that ``--log-format`` names wrongly: ``fmt`` reads it."""
    return f"read it with --log-format {fmt}"


#: a rosbag2 split storage file's name without its suffix: the bag's name, then its split index
#: as rosbag2 writes it (``wbag_0``, ``wbag_12``; never padded, so ``scene_00`` is no split)
_SPLIT = re.compile(r"(?P<bag>.+)_(?P<index>0|[1-9][0-9]*)")


def _refuse_folder_of_logs(folder: Path) -> None:
    """A folder without metadata.yaml whose storage files are several .mcap files but not the
    split files of one bag (no .db3, no first split ``NAME_0.mcap``): the logs ``aion simulate
    --scenes`` writes, which were read as one bag, their messages interleaved into one
    recording. Refused, naming them (:func:`_refuse_other_logs` has refused a folder that also
    holds bags or bag folders). One .mcap file alone is still read as a bag."""
    from aion_cli.formats import rosbag2_storage as storage

    logs = storage.storage_files(folder)
    stems = {Path(storage.inner_name(f)).stem for f in logs}
    if len(logs) < 2 or any(log_suffix(f) == ".db3" for f in logs):
        return  # sqlite3 storage is only ever a rosbag2 bag's
    if any((m := _SPLIT.fullmatch(s)) and f"{m['bag']}_0" in stems for s in stems):
        return  # a split bag's storage files, NAME_0.mcap first
    names = sorted(p.name for p in logs)
    ends = sorted({p.name[len(Path(storage.inner_name(p)).stem) :] for p in logs})
    raise LogFormatError(
        f"{folder} holds {len(logs)} logs ({first_few(names, 5)}), not the storage files of "
        "one rosbag2 bag (it has no metadata.yaml, no .db3, no NAME_0.mcap)",
        hint="give the logs themselves: aion build "
        + " ".join(f"{folder}/*{end}" for end in ends),  # sc/*.mcap, sc/*.mcap.zst
    )


def _refuse_other_logs(folder: Path) -> None:
    """A folder without metadata.yaml is read as the storage files of one rosbag2 bag, which
    leaves out anything else in it: refuse one that also holds other logs (ROS 1 bags, named
    as :func:`guess_format` reads them, ``.bag`` or compressed ``.bag.zst``; rosbag2 folders)
    rather than read its storage files alone without a word."""
    from aion_cli.formats import rosbag2_storage as storage

    others = sorted(
        p.name
        for p in folder.iterdir()
        if (p.is_file() and LOG_SUFFIXES.get(log_suffix(p)) == "bag")
        or (p.is_dir() and ((p / "metadata.yaml").is_file() or storage.storage_files(p)))
    )
    if others:
        raise LogFormatError(
            f"{folder} holds other logs beside its rosbag2 storage files "
            f"({first_few(others, 5)}): a folder without metadata.yaml is read as the storage "
            "files of one bag, which would leave them out",
            hint=f"give the logs one by one ({folder}/*), not their folder",
        )


def _what_else(path: Path) -> str | None:
    """A hint when ``path`` is another input aion reads, given where a log belongs: an aion
    map, a scene-graph file, a tracks CSV (:func:`formats.input_kind.input_kind`)."""
    from aion_cli.formats.input_kind import input_kind
    from aion_cli.formats.track_sniff import guess_layout

    name = path.name
    truth = re.fullmatch(r"(.+)\.truth\.(?:json|npz)", name)
    if truth is not None and (path.parent / truth.group(1)).exists():
        # `aion build day*` picks up what `aion simulate` wrote beside day1.mcap
        return (
            f"{name} is the ground truth `aion simulate` wrote beside the log "
            f"{truth.group(1)}: build from the log alone (`aion evaluate` reads the truth)"
        )
    kind = input_kind(path)
    word = path_word(path)  # the path in a command to paste
    if kind == "map":
        return (
            f"{name} is an aion map, not a log: extend it with `aion build LOG --map {word}`, "
            f"query it with `aion predict {word}`"
        )
    if kind == "graph":
        return f"{name} looks like a scene-graph file: give it to `aion build` with --graph {word}"
    guess = guess_layout(path) if kind is None else None
    if guess is not None:
        return (
            f"{name} looks like a tracks file in {guess.describe()}: make it a log first, "
            f"`aion convert {word} --layout {guess.layout} -o {path_word(path.stem + '.mcap')}`"
        )
    return None


def trailing_warning(path: Path, end: int, size: int) -> str:
    """The warning for a file whose log ends at byte ``end`` of its ``size``: the bytes after
    it are not read. Names what they start with when it is a log of its own (two recordings
    joined into one file: ``cat a.mcap b.mcap``), so the user knows a log was left out."""
    from aion_cli.formats import rosbag2_storage as storage

    with path.open("rb") as f:
        f.seek(end)
        kind = storage.kind_of(f.read(16))
    rest = size - end
    what = (
        f"they hold another log ({_CONTENTS[kind][0]}, appended to this one?): split the "
        f"file at byte {end:,} to read it"
        if kind is not None
        else "they are not part of it (data appended after the log was closed?)"
    )
    return (
        f"{path.name}: the log ends at byte {end:,} of {size:,}; the {rest:,} byte"
        f"{'' if rest == 1 else 's'} after it are not read: {what}"
    )
