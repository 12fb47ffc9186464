"""What an earlier export left in a folder that a new one must not keep beside its own files
(no click or rich here): the scene parts a new export does not write, which it would leave
standing (:func:`drop_stale_parts`: a path, the nodes of another map), and the frames of an
earlier, longer series that a new series does not write (:func:`drop_stale_frames`, and
:func:`stale_note`, what the command and the API say of them).

Only files an export itself wrote go: every export into a folder records the files it wrote
(their path in the folder, size and sha256) in the folder's hidden
:data:`MANIFEST` (:func:`record_written`), and a later export removes only files listed
there that still hold the very bytes that were written (:func:`_still_written`). A scene that
``aion plan --export out/arrows.ply`` saved, a file the user put there or rewrote since, and
every file of a folder with no manifest (an export of an earlier aion) stay. Nor does an
export replace a same-named file no export into the folder wrote (:func:`check_written_here`,
:func:`replaceable`) unless forced, and then only a file of aion's (:func:`is_export_file`).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

#: a series' frame folder: its time in UTC, as ``exports.frame_name`` names it
FRAME_NAME = re.compile(r"\d{8}T\d{6}Z")

MANIFEST = ".aion-export.json"
"""The hidden file in a folder exported into that lists the files exports wrote there."""

_KIND = "aion export files"
"""The manifest's ``kind``: a file of that name without it is not ours (never replaced)."""

Written = dict[str, tuple[int, str]]
"""Files an export wrote: path relative to the folder (``/``-separated) -> (size, sha256)."""


@dataclass
class StaleFrames:
    """The frame folders of an earlier series that :func:`drop_stale_frames` emptied:
    ``removed`` (gone), ``kept`` (aion's files gone, the folder kept for files of someone
    else's)."""

    removed: list[Path] = field(default_factory=list)
    kept: list[Path] = field(default_factory=list)


def read_written(out_dir: Path) -> Written:
    """The files earlier exports wrote into ``out_dir`` (its :data:`MANIFEST`); none when
    it has no manifest or one that cannot be read."""
    try:
        doc = json.loads((out_dir / MANIFEST).read_bytes())
        files = doc["files"] if doc.get("kind") == _KIND else {}
        return {
            str(rel): (int(v[0]), str(v[1]))
            for rel, v in files.items()
            if isinstance(v, list) and len(v) == 2
        }
    except (OSError, ValueError, TypeError, AttributeError, KeyError, RecursionError):
        return {}


def _stamp(path: Path) -> tuple[int, str] | None:
    """(size, sha256) of the regular file ``path`` (never following a link); None else."""
    if os.path.islink(path) or not os.path.isfile(path):
        return None
    try:
        with open(path, "rb") as fh:
            return (os.fstat(fh.fileno()).st_size, hashlib.file_digest(fh, "sha256").hexdigest())
    except OSError:
        return None


def _still_written(out_dir: Path, rel: str, owned: Written) -> bool:
    """Whether ``out_dir / rel`` is listed in ``owned`` and is still the file an export
    wrote there (the same bytes: not replaced or rewritten since)."""
    return rel in owned and _stamp(out_dir / rel) == owned[rel]


def _rel(out_dir: Path, path: Path) -> str:
    return Path(os.path.relpath(path, out_dir)).as_posix()


def drop_stale_frames(out_dir: Path, frames: Collection[str], owned: Written) -> StaleFrames:
    """Remove from ``out_dir`` the frame folders of an earlier series (named as a frame, not
    among ``frames``, the ones this series wrote): a folder holding frames of two runs would
    play the old run's extra times after the new one's. Only files ``owned`` lists (an
    earlier export's, unchanged since) go; a folder left holding anything else is kept with
    it. Symbolic links are never followed."""
    stale = StaleFrames()
    with os.scandir(out_dir) as children:
        folders = sorted(
            Path(c.path)
            for c in children
            if c.is_dir(follow_symlinks=False)
            and FRAME_NAME.fullmatch(c.name)
            and c.name not in frames
        )
    for folder in folders:
        ours = [f for f in folder.iterdir() if _still_written(out_dir, _rel(out_dir, f), owned)]
        if not ours:
            continue  # a folder of someone else's that happens to be named as a frame
        for f in ours:
            f.unlink()
        if any(folder.iterdir()):
            stale.kept.append(folder)
        else:
            folder.rmdir()
            stale.removed.append(folder)
    return stale


def stale_note(stale: StaleFrames, out: Path) -> str | None:
    """What :func:`drop_stale_frames` removed from ``out``, as ``aion export`` notes it and
    ``Map.export`` returns it in its ``notes`` (plain text; None when it removed nothing):
    the frames gone, and the frame folders kept for files aion did not write."""
    gone = [p.name for p in stale.removed]
    kept = [p.name for p in stale.kept]
    parts = []
    if gone:
        span = gone[0] if len(gone) == 1 else f"{gone[0]} to {gone[-1]}"
        parts.append(f"{len(gone)} frame(s) ({span})")
    if kept:
        shown = ", ".join(kept[:3]) + (", ..." if len(kept) > 3 else "")
        parts.append(
            f"aion's files of {len(kept)} more, which keep the files aion did not write "
            f"({shown})"
        )
    if not parts:
        return None
    return f"removed from {out} what an earlier series wrote for times this one has not: " + (
        "; ".join(parts)
    )


def drop_stale_parts(
    out_dir: Path, folders: Sequence[Path], fmt: str, written: Sequence[Path], owned: Written
) -> None:
    """Remove from ``folders`` the scene parts (``<part>.<fmt>``) an earlier export wrote
    (``owned``, unchanged since) that this one did not: left beside the new files, a viewer
    opening the folder would draw them as part of this scene (the path planned for another
    time when this export draws none; the nodes, arrows and edges of a map with a scene
    graph beside the cells of one without, or the arrows of a busier time beside a scene
    without any). A file of that name another command wrote (``aion plan --export
    arrows.ply``) is no export's part and stays."""
    from aion_cli.formats.export import SCENE_PARTS

    keep = {os.path.abspath(p) for p in written}
    for folder in folders:
        for part in SCENE_PARTS:
            old = folder / f"{part}.{fmt}"
            if os.path.abspath(old) in keep:
                continue
            if _still_written(out_dir, _rel(out_dir, old), owned):
                old.unlink()


def replaceable(out_dir: Path, owned: Written, force: bool) -> Callable[[Path], bool]:
    """Whether an export into ``out_dir`` may replace the same-named file it is given: one
    an earlier export wrote there (``owned``, unchanged since); with ``force`` also any file
    of aion's export kinds (:func:`is_export_file`: a scene ``aion plan --export`` saved
    there, an export's file changed since, a file of a folder an aion exported into before
    folders kept the list). Never a file of someone else's."""

    def ours(path: Path) -> bool:
        return _still_written(out_dir, _rel(out_dir, path), owned) or (
            force and is_export_file(path)
        )

    return ours


def check_names_free(out_dir: Path, folders: Sequence[str], fmt: str) -> None:
    """Before any frame is computed: a file of someone else's (not aion's:
    :func:`is_export_file`) in ``out_dir`` (or its subfolders ``folders``: a series' frames)
    under a name the export may write refuses the export."""
    from aion_cli.formats.export import SCENE_PARTS
    from aion_cli.formats.outputs import check_replaceable

    if not out_dir.is_dir():
        return
    names = [f"{part}.{fmt}" for part in SCENE_PARTS] + ["entries.csv", "entries.json"]
    check_replaceable(
        (out_dir / folder / name for folder in folders for name in names), is_export_file
    )


def check_written_here(out_dir: Path, paths: Iterable[Path], owned: Written, force: bool) -> None:
    """Before the files an export staged (to go to ``paths`` in ``out_dir``) are moved in:
    :class:`OutputPathError` for the first that would replace a file no export into
    ``out_dir`` wrote (``owned``; a file of aion's, with ``force``: :func:`replaceable`),
    naming it; the staged files are then discarded."""
    from aion_cli.formats.outputs import OutputPathError, is_empty_file

    ours = replaceable(out_dir, owned, force)
    for dest in paths:
        if os.path.lexists(dest) and not is_empty_file(dest) and not ours(dest):
            why = (
                "another aion command's output, such as a scene `aion plan --export` saved, "
                "or an export's file changed since"
                if (out_dir / MANIFEST).exists()
                else f"{out_dir} has no {MANIFEST}, the list of files exports wrote there: "
                "another command's output, or an export of an aion older than the list"
            )
            raise OutputPathError(
                f"{dest} exists and no export into {out_dir} wrote it ({why}): refusing to "
                "replace it; nothing was written",
                hint="--force replaces it; or export into another folder",
            )


def is_export_file(path: Path) -> bool:
    """Whether ``path`` is a file an export of aion wrote, which a new export may replace:
    a PLY / PCD scene file with aion's marker (:mod:`formats.scene_files`), an
    ``entries.csv`` beginning with the columns of ``aion predict`` (with or without the
    last, ``hour_observed``, which exports before it lacked), an ``entries.json``
    holding a predict document (:data:`PREDICT_KEYS`, its ``mode`` predicted or historical:
    a file of the user's with a ``map`` and ``entries`` of its own is not one)."""
    from aion_cli.formats.scene_files import is_aion_scene_file
    from aion_cli.predictions import CSV_KEYS

    if path.suffix.lower() in (".ply", ".pcd"):
        return is_aion_scene_file(path)
    try:
        if path.name == "entries.csv":
            with open(path, encoding="utf-8", errors="replace") as fh:
                columns = fh.readline().rstrip("\r\n").split(",")
            keys = [re.sub(r"_\d+$", "", c) for c in columns]  # histogram_0.. -> histogram
            keys = [k for i, k in enumerate(keys) if i == 0 or k != keys[i - 1]]
            # an export before hour_observed ended its columns with name
            return keys in (CSV_KEYS, CSV_KEYS[: CSV_KEYS.index("hour_observed")])
        if path.name == "entries.json":  # the keys of predict's document, not any "map"
            doc = json.loads(path.read_bytes())
            return (
                isinstance(doc, dict)
                and doc.keys() >= PREDICT_KEYS
                and doc["mode"] in ("predicted", "historical")
            )
    except (OSError, ValueError, RecursionError):
        return False
    return False


PREDICT_KEYS = frozenset({"map", "mode", "time_ns", "bins", "bin_centres_deg", "entries"})
"""Keys every ``aion predict`` JSON document holds (``predictions.document``)."""


def record_written(out_dir: Path, owned: Written, written: Iterable[Path]) -> None:
    """Write ``out_dir``'s :data:`MANIFEST`: the files of ``owned`` that are still as an
    export wrote them (not removed, replaced or rewritten) and the files ``written`` now. A
    file of that name that is not a manifest of aion's is left as it is."""
    from aion_cli.formats.outputs import Staged, is_empty_file

    target = out_dir / MANIFEST
    if target.exists() and not (is_empty_file(target) or _is_manifest(target)):
        return
    now = {_rel(out_dir, p): p for p in written}
    files = {
        rel: v
        for rel, v in owned.items()
        if rel not in now and _still_written(out_dir, rel, owned)
    }
    for rel, path in now.items():
        stamp = _stamp(path)
        if stamp is not None:
            files[rel] = stamp
    doc = {"kind": _KIND, "files": {rel: list(v) for rel, v in sorted(files.items())}}
    with Staged(target) as staged:
        staged.path.write_text(json.dumps(doc) + "\n", encoding="utf-8")


def _is_manifest(path: Path) -> bool:
    with contextlib.suppress(OSError, ValueError, RecursionError):
        doc = json.loads(path.read_bytes())
        return isinstance(doc, dict) and doc.get("kind") == _KIND
    return False
