"""Which of aion's inputs a file is, from its first bytes: a log, an aion map or a saved scene
graph (a tracks CSV is told by :func:`formats.track_sniff.guess_layout`). One detector for
the errors that meet a file where another input belongs (a map given as a log, a log given
as a map or as tracks): they name what the file is and where it goes. It never raises: a
file it cannot place (or read) is None.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from aion_cli.errors import AionError

InputKind = Literal["log", "map", "graph"]

#: bytes read to tell a saved scene graph by its JSON keys
HEAD_BYTES = 4096
_GRAPH_WORDS = (b'"nodes"', b'"edges"', b'"layer_ids"', b'"directed"')


def input_kind(path: str | Path) -> InputKind | None:
    """``"log"`` (MCAP, ROS 1 bag, rosbag2 storage), ``"map"`` (a zip holding an aion
    manifest), ``"graph"`` (a ``.sparkdsg`` file, or JSON with a graph's keys near its start),
    or None."""
    import zipfile

    from aion_cli.formats.mapfile import MANIFEST_NAME
    from aion_cli.formats.rosbag2_storage import sniff

    p = Path(path)
    try:
        if not p.is_file():
            return None
        if sniff(p) is not None:
            return "log"
        if zipfile.is_zipfile(p):
            with zipfile.ZipFile(p) as archive:
                return "map" if MANIFEST_NAME in archive.namelist() else None
        with p.open("rb") as fh:
            head = fh.read(HEAD_BYTES)
    # zipfile raises NotImplementedError for a damaged "version needed to extract" field (and
    # EOFError for some cut archives); AionError: damaged zstd, say
    except (OSError, ValueError, EOFError, NotImplementedError, zipfile.BadZipFile, AionError):
        return None
    if p.suffix.lower() == ".sparkdsg" or (
        head.lstrip().startswith(b"{") and any(word in head for word in _GRAPH_WORDS)
    ):
        return "graph"
    return None


def bare_zip(path: str | Path) -> tuple[str, str] | None:
    """``(message, hint)`` when ``path`` is a zip archive holding no aion map manifest: not an
    aion map and not a log, whether it was given as one or the other (``aion info`` said it
    could not tell the log format, ``aion predict`` named its first member "unsafe"); None
    otherwise (an aion map, another file, or an unreadable one)."""
    import zipfile

    from aion_cli.formats.mapfile import MANIFEST_NAME

    p = Path(path)
    try:
        if not p.is_file() or not zipfile.is_zipfile(p):
            return None
        with zipfile.ZipFile(p) as archive:
            if MANIFEST_NAME in archive.namelist():
                return None
    except (OSError, ValueError, EOFError, NotImplementedError, zipfile.BadZipFile):
        return None
    return (
        f"{p} is a zip archive without an aion map manifest (no {MANIFEST_NAME} inside): "
        "neither an aion map nor a log",
        "pass a map written by `aion build` (.aion) or a log (.mcap, .bag, a rosbag2 folder); "
        "if it was an aion map, it is damaged: rebuild it from the logs",
    )
