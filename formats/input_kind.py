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
    except (OSError, ValueError, zipfile.BadZipFile, AionError):  # damaged zstd, say
        return None
    if p.suffix.lower() == ".sparkdsg" or (
        head.lstrip().startswith(b"{") and any(word in head for word in _GRAPH_WORDS)
    ):
        return "graph"
    return None
