"""Writing a map's scenes and tables into a folder: ``aion export``, ``aion plan --export``
and :meth:`aion_cli.Map.export` (no click or rich here).

One frame per time: the scene files (``formats.export`` through ``mapquery.export_map``), and
``entries.csv`` / ``entries.json`` with the records of ``aion predict``. Everything is written
into a hidden staging folder beside ``OUT`` and moved in when complete, so a failure (a bad
time, a full disk, Ctrl-C) leaves no partial export behind; files already in ``OUT`` that the
export does not write are kept (but for the scene parts of the same format an earlier export
wrote that this one does not, a path or the nodes of another map, and the frames of an
earlier, longer series, which the hidden manifest ``.aion-export.json`` lists as an export's:
:mod:`aion_cli.export_stale`), and a
same-named file is replaced only when an export into ``OUT`` wrote it, or when forced and it
is one of aion's (:func:`aion_cli.export_stale.replaceable`): nothing is moved in otherwise.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aion_cli.engine.time_text import Zone
from aion_cli.formats.outputs import Staged, cannot_write
from aion_cli.graph_export import export_dsg

if TYPE_CHECKING:
    from aion_cli.export_stale import StaleFrames


def export_frames(
    loaded: Any,
    map_path: Any,
    out_dir: Path,
    times: Sequence[int | None],
    zone: Zone | None,
    fmt: str = "ply",
    ends: tuple[Any, int, int] | None = None,
    on_frame: Callable[[], None] | None = None,
    *,
    series: bool = False,
    force: bool = False,
) -> Exported:
    """Write one frame per time of ``times`` (None: historical) into ``out_dir``, with the
    path between ``ends`` (from :func:`path_ends`) drawn in each; the files written. A
    ``series`` (``--from/--to``) writes one subfolder per time, named by it, however many
    times it has (a series that happens to hold one time keeps the layout a script reading
    the series expects), and removes the frames of an earlier series that this one does not
    write (``Exported.stale``); one time that is not a series goes straight into
    ``out_dir``. A series' spheres share one size scale (``scene_frames.series_flow_scale``,
    as the MCAP and PNG series do), so a sphere that grows from frame to frame is busier.
    Same-named files are replaced only when an export into ``out_dir`` wrote them, or with
    ``force`` when they are any of aion's (:func:`aion_cli.export_stale.replaceable`)."""
    from aion_cli.export_stale import (
        StaleFrames,
        check_names_free,
        check_written_here,
        drop_stale_frames,
        drop_stale_parts,
        read_written,
        record_written,
        replaceable,
    )
    from aion_cli.scene_frames import series_flow_scale

    if not series and len(times) != 1:
        raise ValueError("times other than one are a series (a bug)")
    check_out_dir(out_dir)
    owned = read_written(out_dir)  # what earlier exports wrote here: all they may replace
    check_names_free(out_dir, [frame_name(t) for t in times] if series else [""], fmt)
    written: list[Path] = []
    scale = series_flow_scale(loaded, times) if series else None
    ours = replaceable(out_dir, owned, force)
    with naming(out_dir), Staged(out_dir, merge=True, recognise=ours) as staged:
        staged.path.mkdir()
        for t_ns in times:
            folder = staged.path / frame_name(t_ns) if series else staged.path
            written.extend(_export_one(loaded, t_ns, zone, folder, fmt, ends, map_path, scale))
            if on_frame is not None:
                on_frame()
        moved = [out_dir / p.relative_to(staged.path) for p in written]
        check_written_here(out_dir, moved, owned, force)  # before they are moved in
    folders = [out_dir / frame_name(t) for t in times] if series else [out_dir]
    drop_stale_parts(out_dir, folders, fmt, moved, owned)
    names = {f.name for f in folders}
    stale = drop_stale_frames(out_dir, names, owned) if series else StaleFrames()
    record_written(out_dir, owned, moved)
    return Exported(moved, stale=stale)


@contextlib.contextmanager
def naming(target: Path) -> Iterator[None]:
    """A scene file that could not be written (``ExportWriteError``, named by its file name
    in the hidden staging folder), or a write that failed without naming its file (closing a
    file on a full disk), reported with the output the user named."""
    from aion_cli.formats.export import ExportWriteError

    try:
        yield
    except ExportWriteError as exc:
        raise ExportWriteError(
            f"{exc.message}; nothing was written to {target}", hint=exc.hint
        ) from exc
    except OSError as exc:
        if exc.filename is None:  # a failed close (a full disk) names no file
            exc.filename = str(target)
        raise


def check_out_dir(out_dir: Path) -> None:
    """OUT must be a folder or a new path in an existing folder: never a file, device, FIFO
    or socket (OUT itself is made; the folders above it are not)."""
    from aion_cli.formats.outputs import OutputPathError, check_output_folder, special_kind

    kind = special_kind(out_dir)
    if kind is not None:
        raise OutputPathError(
            f"{out_dir} is {kind}, not a folder", hint="give a folder to write into"
        )
    if out_dir.exists() and not out_dir.is_dir():
        raise OutputPathError(
            f"{out_dir} is a file, not a folder", hint="give a folder to write into"
        )
    if out_dir.is_symlink() and not out_dir.exists():  # the folder is made, never the link's
        raise OutputPathError(
            f"{out_dir} is a dangling symbolic link (to {os.readlink(out_dir)}), not a folder",
            hint="make the folder it points to, remove the link, or give another folder",
        )
    if not out_dir.exists():
        refuse_file_name(out_dir)
    check_output_folder(out_dir)


#: suffixes of files aion reads or writes, and of a map: a new folder named so is a slip that
#: shows only later (``aion report MAP -o report.html`` made report.html/index.html, ``aion
#: export MAP -o map.jpg`` a folder of PLY files named map.jpg)
PICTURE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".svg", ".pdf"})


def refuse_file_name(out_dir: Path) -> None:
    """Refuse (:class:`OutputPathError`) the new folder ``out_dir`` when its name ends in the
    suffix of a kind of file (:data:`formats.mapfile_target.OTHER_SUFFIXES`, ``.aion``,
    ``.txt``, ``.zip``, ``.md``): the files would be written into a folder that looks like one
    file (``aion evaluate report -o report.md`` as well).
    An existing folder so named is the user's and is written into."""
    from aion_cli.formats.mapfile_target import OTHER_SUFFIXES
    from aion_cli.formats.outputs import OutputPathError

    suffix = out_dir.suffix.lower()
    if suffix not in OTHER_SUFFIXES | {".aion", ".txt", ".zip", ".md"}:
        return
    bare = out_dir.with_suffix("")
    picture = (
        f"a picture: --format png -o {bare.name}.png (aion export); "
        if suffix in PICTURE_SUFFIXES else ""
    )  # fmt: skip
    raise OutputPathError(
        f"{out_dir} would be a new folder named as a {suffix} file: the files are written "
        "into a folder",
        hint=f"{picture}name the folder without {suffix}, e.g. {bare}/",
    )


def frame_name(t_ns: int | None) -> str:
    from aion_cli.engine.time_text import utc_of  # cut to the second, not float-rounded

    if t_ns is None:
        return "historical"
    return utc_of(t_ns).strftime("%Y%m%dT%H%M%SZ")


def _export_one(
    loaded: Any,
    t_ns: int | None,
    zone: Zone | None,
    folder: Path,
    fmt: str,
    ends: tuple[Any, int, int] | None,
    map_path: Path,
    flow_scale: float | None = None,
) -> list[Path]:
    from aion_cli.engine import query
    from aion_cli.entry_columns import entry_columns
    from aion_cli.entry_text import predict_csv, predict_json
    from aion_cli.predictions import CSV_KEYS, document, hour_flags, scene_about

    folder.mkdir(parents=True, exist_ok=True)
    table = (
        query.historical_table(loaded.state)
        if t_ns is None
        else query.predict_table(loaded.state, t_ns)
    )
    columns = entry_columns(table)  # every row, in table order: predict's records
    path_rows = None if ends is None else planned_path(loaded, t_ns, ends)
    about = scene_about(loaded, t_ns, zone)
    files = write_scene(loaded, table, folder, fmt, path_rows, flow_scale, about)
    # the text of to_csv / to_json of the records, written a block of entries at a time
    (seen,) = hour_flags(loaded, [t_ns])
    with open(folder / "entries.csv", "w") as fh:
        fh.writelines(predict_csv(columns, CSV_KEYS, seen))
    doc = document(map_path, loaded.config.bins, [], t_ns, zone, seen)
    with open(folder / "entries.json", "w") as fh:
        fh.writelines(predict_json(doc, columns))
    return [*files, folder / "entries.csv", folder / "entries.json"]


def path_ends(
    loaded: Any, path_from: str, path_to: str, snapped: list[dict[str, Any]] | None = None
) -> tuple[Any, int, int]:
    """The planning graph and the node ids of ``--path-from`` / ``--path-to`` (a graph with
    no path between them is a ``NoPathError`` now, before any file is written); ``snapped``
    gets the ``snapped`` record of each end given as a point, room or building (as ``aion
    plan --format json`` lists them)."""
    from aion_cli.mapquery import entry_positions, nav_graph
    from aion_cli.routes import plan_routes, resolve_ends

    nav = nav_graph(loaded)
    a, b = resolve_ends(path_from, path_to, nav, loaded.graph, entry_positions(loaded.state))
    if snapped is not None:
        records = (a.snapped("--path-from"), b.snapped("--path-to"))
        snapped.extend(r for r in records if r is not None)
    plan_routes(loaded, a.node_id, b.node_id, None, nav=nav)
    return nav, a.node_id, b.node_id


HISTORICAL_PATH = (
    "--historical has no time to forecast a path's costs at: the path drawn is the shortest "
    "by distance (give --time for one that avoids busy, opposing flows)"
)
"""The note of a path drawn with ``--historical`` (:func:`planned_path`), which ``aion
export`` prints and ``Map.export`` returns (in the API's words: ``historical=True``)."""


def planned_path(loaded: Any, t_ns: int | None, ends: tuple[Any, int, int]) -> Any:
    """Positions f64[p,3] of the (temporal) path planned at ``t_ns`` between ``ends`` (from
    :func:`path_ends`); distance only for a historical export (``t_ns`` None)."""
    from aion_cli.routes import plan_routes

    nav, a, b = ends
    return nav.xyz[plan_routes(loaded, a, b, t_ns, nav=nav).temporal.rows]


def write_scene(
    loaded: Any,
    table: Any,
    folder: Path,
    fmt: str,
    path_xyz: Any | None,
    flow_scale: float | None = None,
    about: Sequence[str] = (),
) -> list[Path]:
    """The scene files for one time (``formats.export`` via ``mapquery.export_map``), its
    spheres sized on ``flow_scale`` (None: the scene's own), each header with the comments
    ``about`` (``predictions.scene_about``: the time, whether its hour was observed)."""
    from aion_cli.mapquery import export_map

    return export_map(loaded, table, folder, fmt, path_xyz, flow_scale=flow_scale, about=about)


def export_plan_scene(
    loaded: Any, t_ns: int, nav: Any, path: Any, out: Path, zone: Zone | None = None
) -> None:
    """The whole scene at ``t_ns`` (said in ``zone`` in its header) with a planned path, as
    the one PLY file ``out`` (``aion plan --export``; see :func:`export_scene_file`)."""
    check_plan_export(out)
    export_scene_file(loaded, t_ns, out, "ply", nav.xyz[path], zone)


def check_plan_export(out: Path) -> None:
    """Refuse ``aion plan --export`` 's ``out`` before any planning, as ``--png`` is: a name
    that is no ``.ply`` file, a missing folder, a device, a file aion's export did not write
    (a ``--leave`` of many departures had been planned first, then refused)."""
    from aion_cli.errors import InputError

    if out.suffix.lower() != ".ply":
        raise InputError(
            f"--export writes a .ply file, got {out.name!r}",
            hint=f"name it {out.with_suffix('.ply').name}",
        )
    check_scene_file(out, "ply")


SCENE_FORMATS = ("ply", "pcd")


def scene_file(fmt: str, out: Path) -> bool:
    """Whether a PLY / PCD export names one scene file (``-o scene.ply``: the whole scene in
    one file, as ``scene.ply`` of a folder export) rather than a folder to write into."""
    return fmt in SCENE_FORMATS and out.suffix.lower() == f".{fmt}" and not out.is_dir()


def export_scene_file(
    loaded: Any,
    t_ns: int | None,
    out: Path,
    fmt: str,
    path_xyz: Any | None,
    zone: Zone | None = None,
) -> Path:
    """The whole scene at ``t_ns`` (None: as observed; its header says the time in ``zone``
    and whether its hour was observed), with the path ``path_xyz`` if given, as the one PLY
    or PCD file ``out``: written beside ``out`` and renamed into place; an existing ``out``
    is replaced only when an export wrote it (never a device, FIFO, or a PLY / PCD file of
    someone else's)."""
    from aion_cli.engine import query
    from aion_cli.errors import InputError
    from aion_cli.predictions import scene_about

    check_scene_file(out, fmt)
    table = (
        query.historical_table(loaded.state)
        if t_ns is None
        else query.predict_table(loaded.state, t_ns)
    )
    with cannot_write(out), naming(out), Staged(out) as staged:
        scratch = staged.folder / "scene"  # the other files are dropped with the staging
        scratch.mkdir()
        files = write_scene(
            loaded, table, scratch, fmt, path_xyz, about=scene_about(loaded, t_ns, zone)
        )
        scene = [f for f in files if f.name == f"scene.{fmt}"]
        if not scene:  # a map without places, cells or mesh: no part, no scene file
            raise InputError(
                f"nothing to draw in {out}: the map has no places, hash cells or mesh",
                hint="aion info MAP shows what it holds; build it from a log with people "
                "detections",
            )
        scene[0].rename(staged.path)
    return out


def check_scene_file(out: Path, fmt: str) -> None:
    """Refuse the one-file PLY / PCD target ``out`` before anything is computed: a device, a
    missing folder, an existing file that is not a scene an export wrote."""
    from aion_cli.formats.outputs import check_output
    from aion_cli.formats.scene_files import is_aion_scene_file

    check_output(
        out, overwrite=True, recognise=is_aion_scene_file, what=f"a {fmt.upper()} scene",
        option=None,
    )  # fmt: skip


FILE_FORMATS = {".png": "png", ".mcap": "mcap", ".json": "dsg", ".sparkdsg": "dsg"}
"""Output suffixes that name one file, and the format that writes it."""
FORMAT_SUFFIX = {"png": ".png", "mcap": ".mcap", "dsg": ".json", "ply": ".ply", "pcd": ".pcd"}


def export_format(fmt: str | None, out: Path) -> str:
    """The format to write: ``fmt`` if given (``--format``), else the one the output's suffix
    names (:data:`FILE_FORMATS`, .ply / .pcd: :func:`scene_file`), else ply (a folder). Refused
    rather than written under a misleading name: a suffix naming another format (``--format png
    -o x.mcap``) or a table (``-o flows.csv``, but for an existing folder), or only a suffix."""
    from aion_cli.errors import InputError

    named = {**FILE_FORMATS, ".ply": "ply", ".pcd": "pcd", ".csv": "table"}
    if out.name.lower() in named and not out.is_dir():  # Path(".png").suffix is ""
        raise InputError(
            f"{str(out)!r} is only a suffix: name the file before it",
            hint=f"e.g. map{out.name.lower()}, or a folder (e.g. out/) for PLY frames",
        )
    said = named.get(suffix := out.suffix.lower())
    default = "" if fmt else " (the default)"
    fmt = fmt or (said if said and said != "table" else "ply")
    if said not in (None, fmt) and not (fmt in SCENE_FORMATS and out.is_dir()):
        raise InputError(
            f"the format {fmt}{default} and the name {str(out)!r} disagree: {suffix} is the "
            f"suffix of {'a table' if said == 'table' else f'format {said}'}",
            hint=f"name it {out.with_suffix(FORMAT_SUFFIX[fmt]).name}"
            + (", or a folder (e.g. out/)" if fmt in SCENE_FORMATS else "")
            + ("; the table alone: aion predict MAP --time T --format csv > FILE.csv"
               if said == "table" else f", or give the format {said}"),
        )
    return fmt


@dataclass(frozen=True)
class Exported:
    """What :func:`write_export` wrote: the files, for ``dsg`` the graph's summary
    (``formats.dsg_export.DsgExportSummary``: its places, rooms, edges), and for a series
    of frames the frames of an earlier series it removed (``export_stale.StaleFrames``)."""

    files: list[Path]
    graph: Any = None
    stale: StaleFrames | None = None


def write_export(
    loaded: Any,
    label: Any,
    out: Path,
    times: Sequence[int | None],
    zone: Zone | None,
    fmt: str,
    ends: tuple[Any, int, int] | None = None,
    on_frame: Callable[[], None] | None = None,
    *,
    series: bool = False,
    force: bool = False,
) -> Exported:
    """Write the export of ``fmt`` (:func:`export_format`) at ``times`` to ``out``: the
    scene graph, a picture, an MCAP series, one scene file or a folder of frames, named
    after the map ``label``. The one place ``aion export`` and :meth:`aion_cli.Map.export`
    write: ``out`` is checked, then its lock (:func:`formats.output_lock.output_lock`) is
    held until the export is in place, so a second export to the same ``out`` is refused
    instead of mixing its files with this one's."""
    from aion_cli.formats.output_lock import output_lock

    check_export_target(out, fmt)  # a device or a missing folder gets no lock beside it
    with output_lock(out, into=_into(out, fmt)):
        if fmt == "dsg":
            graph = export_dsg(loaded, label, out, times[0], zone)
            if on_frame is not None:
                on_frame()
            return Exported([graph.path], graph)
        if fmt == "png":
            from aion_cli.pictures.render import export_png

            name = Path(os.fsdecode(label)).name
            return Exported([export_png(loaded, name, out, times, zone, ends, on_frame)])
        if fmt == "mcap":
            from aion_cli.scene_frames import export_mcap

            return Exported([export_mcap(loaded, label, out, times, zone, ends, on_frame)])
        if scene_file(fmt, out):
            path_xyz = None if ends is None else planned_path(loaded, times[0], ends)
            written = export_scene_file(loaded, times[0], out, fmt, path_xyz, zone)
            if on_frame is not None:
                on_frame()
            return Exported([written])
        return export_frames(
            loaded, label, out, times, zone, fmt, ends, on_frame, series=series, force=force
        )


def _into(out: Path, fmt: str) -> bool:
    """Whether ``out`` is a folder written into (PLY / PCD frames), not one file."""
    return fmt in SCENE_FORMATS and not scene_file(fmt, out)


def check_export_target(out: Path, fmt: str) -> None:
    """The check of the output each writer of ``fmt`` makes before any work (see each)."""
    if fmt == "dsg":
        from aion_cli.formats.dsg_export import check_dsg_target

        check_dsg_target(out)
    elif fmt == "png":
        from aion_cli.pictures.render import check_png_target

        check_png_target(out)
    elif fmt == "mcap":
        from aion_cli.formats.scene_mcap import check_scene_target

        check_scene_target(out)
    elif scene_file(fmt, out):
        check_scene_file(out, fmt)
    else:
        check_out_dir(out)
