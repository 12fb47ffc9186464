"""What an earlier export left in a folder that a new one must not keep beside its own files
(no click or rich here): the scene parts a new export does not write, which it would leave
standing (:func:`drop_stale_parts`: a path, the nodes of another map), and the frames of an
earlier, longer series that a new series does not write (:func:`drop_stale_frames`). Only
files an export wrote go (:func:`aion_cli.exports.is_export_file`, under the names an export
writes); anything else in the folder, a frame folder's foreign file included, stays.
"""

from __future__ import annotations

import os
import re
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from aion_cli.exports import is_export_file

#: a series' frame folder: its time in UTC, as ``exports.frame_name`` names it
FRAME_NAME = re.compile(r"\d{8}T\d{6}Z")


@dataclass
class StaleFrames:
    """The frame folders of an earlier series that :func:`drop_stale_frames` emptied:
    ``removed`` (gone), ``kept`` (aion's files gone, the folder kept for files of someone
    else's)."""

    removed: list[Path] = field(default_factory=list)
    kept: list[Path] = field(default_factory=list)


def drop_stale_frames(out_dir: Path, frames: Collection[str]) -> StaleFrames:
    """Remove from ``out_dir`` the frame folders of an earlier series (named as a frame, not
    among ``frames``, the ones this series wrote): a folder holding frames of two runs would
    play the old run's extra times after the new one's. Only an export's own files go (a
    scene part or ``entries.csv`` / ``entries.json`` that :func:`is_export_file` recognises);
    a folder left holding anything else is kept with it. Symbolic links are never followed."""
    from aion_cli.formats.export import SCENE_PARTS

    names = {f"{p}.{x}" for p in SCENE_PARTS for x in ("ply", "pcd")} | {
        "entries.csv", "entries.json",
    }  # fmt: skip
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
        files = [f for f in folder.iterdir() if f.name in names and not f.is_symlink()]
        ours = [f for f in files if f.is_file() and is_export_file(f)]
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


def drop_stale_parts(folders: Sequence[Path], fmt: str, written: Sequence[Path]) -> None:
    """Remove from ``folders`` the scene parts (``<part>.<fmt>``) an earlier export wrote that
    this one did not: left beside the new files, a viewer opening the folder would draw them
    as part of this scene (the path planned for another time when this export draws none;
    the nodes, arrows and edges of a map with a scene graph beside the cells of one without,
    or the arrows of a busier time beside a scene without any). Only aion's own scene files
    go (:func:`aion_cli.exports.is_export_file`), and of ``path.<fmt>`` only a path part
    (:func:`_is_path_part`), never a whole scene saved under that name (``aion plan
    --export path.ply``)."""
    from aion_cli.formats.export import SCENE_PARTS

    keep = {os.path.abspath(p) for p in written}
    for folder in folders:
        for part in SCENE_PARTS:
            old = folder / f"{part}.{fmt}"
            if os.path.abspath(old) in keep or not old.is_file() or old.is_symlink():
                continue
            if is_export_file(old) and (part != "path" or _is_path_part(old)):
                old.unlink()


def _is_path_part(path: Path) -> bool:
    """Whether the aion scene file ``path`` holds an export's path part only: a PLY of bare
    vertices and coloured edges (no faces), a PCD of points without normals. A whole scene
    (``plan --export``, ``export -o x.ply``) has its places' spheres (faces) or normals."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    if head.startswith(b"ply\n"):
        header = head[: head.find(b"end_header")]
        elements = [line.split()[1] for line in header.splitlines() if line.startswith(b"element ")]
        return elements == [b"vertex", b"edge"]
    fields = [line for line in head.splitlines() if line.startswith(b"FIELDS ")]
    return fields == [b"FIELDS x y z rgb"]
