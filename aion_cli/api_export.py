"""What :meth:`aion_cli.api.Map.export`'s arguments say together: the format a ``format=`` or
the output's suffix chooses (as ``aion export`` reads ``--format`` and ``-o``), and the
combinations an export refuses in the API's words (a PNG is :meth:`~aion_cli.api.Map.picture`'s,
a spark_dsg file holds neither a path nor a series, a series needs a folder or an MCAP file).

Why a module of its own: :mod:`aion_cli.api` holds the map and its queries; these are the
export's argument rules, one place for each."""

from __future__ import annotations

from pathlib import Path

from aion_cli.errors import InputError

FORMATS = (None, "ply", "pcd", "mcap", "dsg")
"""What ``Map.export(format=...)`` takes (None: the output's suffix chooses)."""


def export_target(format: object, out: Path) -> str:
    """The format of an export into ``out``: ``format``, else what ``out``'s suffix says (as
    ``aion export``); a PNG is refused with the way to it (``Map.picture``)."""
    from aion_cli.exports import export_format

    if format not in FORMATS:
        raise InputError(f"unknown export format {format!r}", hint="ply, pcd, mcap or dsg")
    chosen = export_format(format, out)
    if chosen == "png":
        raise InputError(f"{str(out)!r} names a picture", hint="Map.picture(file) writes the PNG")
    return chosen


def refuse_combination(format: str, out: Path, path: object, series: object) -> None:
    """:class:`InputError` for what an export of ``format`` into ``out`` cannot hold: a path
    (``path`` not None) or a ``series`` in a spark_dsg file, a series in one scene file."""
    from aion_cli.exports import scene_file

    if format == "dsg" and path is not None:
        raise InputError(
            "a scene-graph file holds no path: leave out path",
            hint="format='ply' or format='mcap' draws the path; "
            "Map.picture(file, path=...) draws it as a PNG",
        )
    if format == "dsg" and series is not None:
        raise InputError(
            "a scene-graph file holds one time: leave out series",
            hint="format='ply' or format='mcap' writes a series; "
            "Map.picture(file, series=...) draws it as a PNG",
        )
    if series is not None and scene_file(format, out):
        raise InputError(
            f"a series writes one {format} scene per time into a folder, got a file: {out}",
            hint="name a folder (e.g. 'series/'), or a .mcap file for one file to scrub",
        )
