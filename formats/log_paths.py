"""One path given to ``open_logs`` opened into its sources: a file, the storage files of a
rosbag2 folder, or storage files without a usable metadata.yaml (indexed in memory).

The rules, in order: a zstd-compressed file given alone is read through a decompressed
temporary copy (:func:`_open_compressed`); an MCAP file (or a folder holding exactly one) is
read by aion's MCAP reader; a ROS 1 bag by rosbags; a rosbag2 folder by rosbags, except that
its mcap storage files go to aion's MCAP reader too (faster, and bounded by the read limits),
and a folder without metadata.yaml, or one whose metadata.yaml rosbags refuses (a recording
killed before it finished), or one with a sqlite3 storage file cut short (read as far as SQLite
reads it: :mod:`formats.sqlite_salvage`), is indexed from the storage files themselves, with a
warning that says so.

Why apart from :mod:`formats.logs`: that module merges many sources into one time-ordered
stream and knows nothing of containers; this one knows every container's quirks of opening.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from aion_cli.errors import LogFormatError
from aion_cli.formats.limits import ReadLimits
from aion_cli.formats.log_format import FORMATS, _what_else, guess_format, other_log_hint
from aion_cli.formats.log_source import _Source, _Unpacked
from aion_cli.formats.mcap_source import _open_mcap
from aion_cli.formats.rosbag2_reindex import _reindexed_sources
from aion_cli.formats.rosbag2_storage import metadata_warning, unlisted_storage_files
from aion_cli.formats.rosbags_source import _RosbagsSource
from aion_cli.formats.sqlite_salvage import cut_short
from aion_cli.listing import first_few


def open_sources(path: Path, fmt: str | None, limits: ReadLimits) -> list[_Source]:
    """The sources of one path: one file, the storage files of a rosbag2 folder, or storage
    files without metadata.yaml (reindexed in memory). A storage file beside its bag's
    metadata.yaml opens the whole bag, which a warning says when the bag has more files."""
    sources = _open_path(path, fmt, limits)
    if path.is_file() and path.name != "metadata.yaml" and sources:  # it names the whole bag
        files = sum(_storage_files_read(s) for s in sources)
        if files > 1:
            sources[-1].warnings.append(
                f"{path.name} is read with its whole rosbag2 bag {path.parent} ({files} "
                "storage files): give the folder to say so, or copy the file alone to read it "
                "alone"
            )
    return sources


def _storage_files_read(source: _Source) -> int:
    """How many storage files ``source`` reads (a rosbags reader of a bag of several)."""
    storage = getattr(getattr(source, "_reader", None), "storage", None)
    opened = getattr(storage, "storages", None)  # rosbags' rosbag2 reader: one per file
    if isinstance(opened, list):
        return max(1, len(opened))
    return int(getattr(source, "file_count", 1))


def _open_path(path: Path, fmt: str | None, limits: ReadLimits) -> list[_Source]:
    """:func:`open_sources` without the note on a widened storage file."""
    from aion_cli.formats import rosbag2_storage as storage

    if fmt is not None and fmt not in FORMATS:
        raise LogFormatError(
            f"unknown log format {fmt!r}", hint=f"use one of: {', '.join(FORMATS)}"
        )
    try:
        guessed, target = guess_format(path)
    except LogFormatError:
        if fmt is None or not path.is_file() or path.stat().st_size == 0 or _what_else(path):
            raise  # a map, a scene graph, a tracks file: the guess's hint says what to do
        # the file's name and bytes say no format, but --log-format names one: its reader
        # says why it cannot read the file ("cannot tell the log format" pointed back to
        # the --log-format given)
        guessed, target = fmt, path
    kind = fmt or guessed
    if kind in ("mcap", "bag") and path.is_file() and path.name != "metadata.yaml":
        target = path  # --log-format mcap|bag reads the file named, never its rosbag2 folder
    if (
        target.is_file()
        and storage.is_zstd(target)
        and not (kind == "rosbag2" and (target.parent / "metadata.yaml").is_file())
    ):
        return _open_compressed(target, kind, limits)
    if kind == "mcap":
        if target.is_dir():
            files = sorted(target.glob("*.mcap"))
            if len(files) != 1:  # guess_format let only a rosbag2 folder through
                raise LogFormatError(
                    f"{target} holds {len(files)} .mcap files",
                    hint=f"pass one .mcap file, or the bag: {other_log_hint('rosbag2')}",
                )
            target = files[0]
        return [_open_mcap(target, limits=limits)]
    if kind == "bag":
        return [_RosbagsSource(target, "bag", limits)]
    folder = target.parent if target.is_file() else target
    if not (folder / "metadata.yaml").is_file():
        if target.is_file():
            return _reindexed_sources([target], target, limits)  # one storage file alone
        files = storage.storage_files(folder)
        sources = _reindexed_sources(files, folder, limits)
        one = (
            "; read as one recording, the time between its files included (give the files "
            "themselves if they are separate logs)"
            if len(files) > 1
            else ""
        )
        sources[-1].warnings.append(
            f"{folder}: no metadata.yaml; indexed in memory from its {_files(sources)}, "
            f"as `ros2 bag reindex` would{one}"
        )
        return sources
    files = storage.storage_files(folder)
    short = [f.name for f in files if cut_short(f) is not None]
    if short:  # SQLite opens none of it: what it reads of it, without the yaml's figures
        sources = _reindexed_sources(files, folder, limits)
        sources[-1].warnings.append(
            f"{folder}: metadata.yaml not used ({first_few(short, 3)} cut short); indexed in "
            f"memory from its {_files(sources)}{_of_stated(folder, sources)}"
        )
        return sources
    try:
        source = _RosbagsSource(folder, "rosbag2", limits)
    except LogFormatError as exc:
        # A recording killed before it finished leaves mcap storage files without a summary,
        # which rosbags refuses, or a metadata.yaml that does not match the files: index the
        # storage files themselves; the mcap reader recovers what was written.
        files = storage.storage_files(folder)
        if not files:
            raise
        from aion_cli.formats.log_magic import NotALogError

        try:
            sources = _reindexed_sources(files, folder, limits)
        except NotALogError:
            raise  # a storage file that is no SQLite or MCAP at all: that file is the reason
        except LogFormatError:
            raise exc from None
        sources[-1].warnings.append(
            f"{folder}: metadata.yaml not used ({exc.message}); indexed in memory from its "
            f"{_files(sources)}{_of_stated(folder, sources)}"
        )
        return sources
    found = source.mcap_storage()
    if found is not None:
        # rosbag2 with mcap storage: aion's MCAP reader (faster than rosbags' mcap plugin,
        # and bounded); a whole-file compressed bag is read from rosbags' decompressed copies,
        # which live until the last of these sources is closed
        mcap_files, unzstd = found
        keep = any(original is not None for _, original in mcap_files)
        if not keep:
            source.close()
        mcaps: list[_Source] = []
        try:
            for plain, original in mcap_files:
                mcap = _open_mcap(plain, fmt_name="rosbag2-mcap", limits=limits, unzstd=unzstd)
                mcaps.append(mcap if original is None else _Unpacked(mcap, [], original))
            if keep:
                last = mcaps[-1]
                assert isinstance(last, _Unpacked)
                last.owns(source)
        except BaseException:
            for opened in mcaps:
                opened.close()
            if keep:
                source.close()
            raise
        counted: Counter[tuple[str, str]] = Counter()
        for opened in mcaps:
            for key, t in opened.topics.items():
                counted[key] += t.count
        busy = [m.file for m in mcaps if m.file.message_count]
        warning = metadata_warning(
            folder,
            min((f.start_ns for f in busy), default=0),
            max((f.end_ns for f in busy), default=0),
            sum(counted.values()),
            counted,
        )
        if warning:
            mcaps[0].warnings.append(warning)
        return _unlisted_left_out(folder, mcaps)
    return _unlisted_left_out(folder, [source])


def _unlisted_left_out(folder: Path, sources: list[_Source]) -> list[_Source]:
    """``sources``, with a warning naming the storage files beside the bag's that its
    metadata.yaml does not list, which are not read (they were read as nothing, silently)."""
    unlisted = unlisted_storage_files(folder)
    if unlisted:
        sources[-1].warnings.append(
            f"{folder}: {first_few(unlisted, 3)} beside the bag's storage files "
            f"{'is' if len(unlisted) == 1 else 'are'} not listed in its metadata.yaml: not "
            "read (copy the folder without metadata.yaml to read every storage file: aion "
            "then indexes them, as `ros2 bag reindex` would)"
        )
    return sources


def _of_stated(folder: Path, sources: list[_Source]) -> str:
    """``: 1,207 of the 2,179 messages metadata.yaml counts`` (what was read of the bag, where
    its metadata.yaml gives a count), else nothing."""
    from aion_cli.formats import rosbag2_storage as storage

    figures = storage.metadata_figures(folder)
    stated = figures.message_count if figures is not None else None
    read = sum(s.file.message_count for s in sources)
    return f": {read:,} of the {stated:,} messages metadata.yaml counts" if stated else ""


def _files(sources: list[_Source]) -> str:
    n = sum(getattr(s, "file_count", 1) for s in sources)
    return f"{n} storage file" + ("" if n == 1 else "s")


def _open_compressed(path: Path, kind: str, limits: ReadLimits) -> list[_Source]:
    """A zstd-compressed file given alone (a rosbag2 storage file from a bag recorded with
    ``compression_mode: file``, or a compressed .bag / .mcap): read through a decompressed
    temporary copy that closing the source removes."""
    from aion_cli.formats import rosbag2_storage as storage

    if kind == "rosbag2":
        return _reindexed_sources([path], path, limits)
    tmp, inner = storage.decompress_to_temp(path)
    try:
        source: _Source = (
            _open_mcap(inner, limits=limits)
            if kind == "mcap"
            else _RosbagsSource(inner, "bag", limits)
        )
    except BaseException as exc:
        tmp.cleanup()
        storage.name_original(exc, path, inner)
        raise
    return [_Unpacked(source, [tmp], path)]
