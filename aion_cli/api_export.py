"""What :meth:`aion_cli.api.Map.export`'s arguments say together: the format a ``format=`` or
the output's suffix chooses (as ``aion export`` reads ``--format`` and ``-o``), and the
combinations an export refuses in the API's words (a PNG is :meth:`~aion_cli.api.Map.picture`'s,
a spark_dsg file holds neither a path nor a series, a series needs a folder or an MCAP file);
and what it says of the files it wrote (:func:`written_notes`), as ``aion export`` notes it.

Why a module of its own: :mod:`aion_cli.api` holds the map and its queries; these are the
export's argument rules and notes, one place for each."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from aion_cli.errors import InputError

if TYPE_CHECKING:
    from aion_cli.exports import Exported
    from aion_cli.mapquery import LoadedMap

FORMATS = (None, "ply", "pcd", "mcap", "dsg")
"""What ``Map.export(format=...)`` takes (None: the output's suffix chooses)."""


def export_target(format: object, out: Path) -> str:
    """The format of an export into ``out``: ``format`` in any case (``"PLY"`` as ``aion
    export --format PLY``), else what ``out``'s suffix says (as ``aion export``); a PNG is
    refused with the way to it (``Map.picture``)."""
    from aion_cli.exports import export_format

    if isinstance(format, str):
        format = format.lower()
    if format == "png":  # aion export --format png: here a call of its own
        raise InputError(
            "format='png' is not an export's: a picture is Map.picture's",
            hint=f"Map.picture({str(out)!r}, ...) draws the map as a PNG",
        )
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


def written_notes(
    loaded: LoadedMap, written: Exported, out: Path, drawn_as_observed: bool,
    path_drawn: bool = False,
) -> list[str]:
    """The notes ``aion export`` prints after the forecast's, in its order and the API's
    words (:func:`aion_cli.api_make.warn_of`): that a path drawn as observed is the shortest
    by distance (``drawn_as_observed``: ``historical=True`` with a ``path``), or one drawn at
    a time over places that hold no detection (``path_drawn``), the frames of
    an earlier series the export removed from ``out`` (:func:`aion_cli.export_stale.
    stale_note`), and a scene graph's: what the map does not store, and the detections the
    file leaves out (issued as an ``AionWarning`` instead when they are most of them)."""
    from aion_cli.api_make import warn_of
    from aion_cli.api_results import DISTANCE_PATH, flowless_places_note
    from aion_cli.export_stale import stale_note
    from aion_cli.exports import HISTORICAL_PATH
    from aion_cli.formats.dsg_export import not_stored_note
    from aion_cli.graph_export import cells_left_out

    notes = [HISTORICAL_PATH] if drawn_as_observed else []
    if path_drawn and not drawn_as_observed:  # at a time, over places without people
        flowless = flowless_places_note(loaded.state, DISTANCE_PATH)
        notes += [] if flowless is None else [flowless]
    stale = None if written.stale is None else stale_note(written.stale, out)
    notes += [] if stale is None else [stale]
    warnings: list[str] = []
    if written.graph is not None and (graph := loaded.graph) is not None:
        notes.append(not_stored_note(graph.layer_name))
        left_out = cells_left_out(loaded, "format='ply' or Map.picture")
        if left_out is not None:  # most of the detections: a warning
            (warnings if left_out[1] else notes).append(left_out[0])
    warn_of(warnings, notes)
    return notes
