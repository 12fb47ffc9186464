"""PNG pictures of a loaded map: ``aion export --format png``, ``aion plan --png`` and
:meth:`aion_cli.Map.picture` (no click or rich here).

The scene at each time comes from :func:`aion_cli.scene.scene_at` (the entry table of
``aion predict``), paths from :mod:`aion_cli.routes` (the plans ``aion plan`` prints). A
picture is written beside its target and renamed into place (``formats.outputs.Staged``), so
a failure leaves no partial file; an existing target is replaced only when it is a picture
aion drew (:mod:`aion_cli.pictures.png_mark`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.errors import InputError
from aion_cli.pictures.floors import levels_apart
from aion_cli.pictures.png_mark import is_aion_png, save_marked_png
from aion_cli.pictures.topdown import DPI, MAX_PANELS, Marker, PathLine, topdown_figure

if TYPE_CHECKING:
    from aion_cli.engine.time_text import Zone
    from aion_cli.mapquery import LoadedMap
    from aion_cli.routes import Routes

def map_frame(loaded: LoadedMap | None) -> str | None:
    """The frame the map's positions are in, as its manifest records it (``aion build
    --map-frame``; ``map`` by default); None for a map that does not record it (or none)."""
    frame = (getattr(loaded, "manifest", None) or {}).get("map_frame")
    return frame if isinstance(frame, str) and frame else None


def check_png_target(out: Path, option: str = "-o") -> None:
    """Refuse, before anything is computed, a target that is not a new PNG file or one aion
    drew, in an existing folder (a folder, a device, another file, a PNG picture of someone
    else's, a missing folder): a picture aion drew (or an empty file) is replaced, nothing
    else."""
    from aion_cli.formats.outputs import (
        OutputPathError,
        check_output_folder,
        is_empty_file,
        refusal_hint,
        special_kind,
    )

    kind = special_kind(out)
    if kind is not None:
        raise OutputPathError(f"{option} {out} is {kind}, not a PNG file")
    if out.is_dir():
        raise OutputPathError(
            f"{option} {out} is a folder, not a PNG file",
            hint=f"name the picture, e.g. {option} {out / 'map.png'}",
        )
    if out.suffix.lower() != ".png":
        raise InputError(
            f"{option} writes a .png file, got {out.name!r}",
            hint=f"name it {out.with_suffix('.png').name}",
        )
    check_output_folder(out, f"{option} {out}")
    if os.path.lexists(out) and not (is_empty_file(out) or is_aion_png(out)):
        raise OutputPathError(
            f"{option} {out} exists and is not a picture aion drew: refusing to replace it",
            hint=refusal_hint(None),
        )


def save_png(fig: Any, out: Path, option: str = "-o") -> Path:
    """Write the matplotlib figure ``fig`` to ``out`` atomically (checked first); drawn
    again after its layout is settled when text was cut at the page's edges
    (:func:`.layout.settle`)."""
    from aion_cli.formats.outputs import Staged, cannot_write
    from aion_cli.pictures.layout import settle, text_cut_off

    check_png_target(out, option)
    with cannot_write(out), Staged(out) as staged:
        save_marked_png(fig, staged.path, dpi=fig.dpi, facecolor="white")
        if text_cut_off(fig):  # the first layout left too little room: settled, drawn again
            settle(fig)
            save_marked_png(fig, staged.path, dpi=fig.dpi, facecolor="white")
    return out


def time_title(t_ns: int | None, zone: Zone | None, clock_only: bool = False) -> str:
    """``"Mon 2026-01-12 08:40 UTC"`` (in the map's zone), ``"08:40"`` with ``clock_only``;
    ``"as observed (historical)"`` for None."""
    from aion_cli.engine.time_text import from_ns, offset_text, repeated_wall_clock
    from aion_cli.timeparse import resolve_zone

    if t_ns is None:
        return "as observed (historical)"
    where = zone if zone is not None else resolve_zone("UTC")
    moment = from_ns(t_ns, where)
    # the hour a clock change repeats reads the same twice: its offset says which it is
    offset = f" {offset_text(moment)}" if repeated_wall_clock(moment) else ""
    if clock_only:
        return moment.strftime("%H:%M") + offset
    return f"{moment.strftime('%a %Y-%m-%d %H:%M')}{offset} {where.name}"


def _panel_titles(times: Sequence[int | None], zone: Zone | None) -> list[str]:
    """Panel titles of a series: the clock when every time is on one day, else the day too."""
    from aion_cli.engine.time_text import clock_labels, from_ns
    from aion_cli.timeparse import resolve_zone

    where = zone if zone is not None else resolve_zone("UTC")
    known = [t for t in times if t is not None]
    days = {from_ns(t, where).date() for t in known}
    labels = iter(clock_labels(known, where, "%H:%M" if len(days) <= 1 else "%a %m-%d %H:%M"))
    return ["as observed (historical)" if t is None else next(labels) for t in times]


def _mark_unobserved(
    loaded: LoadedMap, times: Sequence[int | None], titles: list[str]
) -> list[str]:
    """Panel titles, those at an hour no log observed on any day marked "(extrapolated)"
    (as the forecast notes name them, and a series' table its rows); the title of one time
    gets the mark of ``predict --time``'s table on a line of its own
    (:data:`~aion_cli.note_words.EXTRAPOLATED`: a panel's title is not wrapped)."""
    from aion_cli.note_words import EXTRAPOLATED
    from aion_cli.predictions import hour_flags

    flags = hour_flags(loaded, times)
    mark = f"\n{EXTRAPOLATED}" if len(times) == 1 else " (extrapolated)"
    return [
        f"{title}{mark}" if seen is False else title
        for title, seen in zip(titles, flags, strict=True)
    ]


def _name_span(loaded: LoadedMap, times: Sequence[int | None], titles: list[str]) -> list[str]:
    """The title of one time naming what the picture shows beside the map's data: as
    observed, the days of the data (``as observed (historical), 2026-01-05 to 2026-01-09
    UTC``); a forecast over a week before or after them (``aion export`` without
    ``--time`` draws now), how far, on a line of its own
    (:func:`~aion_cli.forecast_notes.far_from_data`). A series, or a map that does not record
    its span, keeps its titles."""
    from aion_cli.forecast_notes import data_days, far_from_data
    from aion_cli.manifest import Manifest

    raw = dict(getattr(loaded, "manifest", None) or {})
    raw.setdefault("state", {})
    manifest = Manifest.from_dict(raw)
    start, end, zone = manifest.start_ns, manifest.end_ns, manifest.timezone
    if len(times) != 1 or start is None or end is None:
        return titles
    if times[0] is None:
        return [f"{titles[0]}, {data_days(start, end, zone)} {zone or 'UTC'}"]
    far = far_from_data(start, end, int(times[0]), zone)
    return titles if far is None else [f"{titles[0]}\n{far}"]


def _series_title(name: str, times: Sequence[int | None], zone: Zone | None) -> str:
    """``"office.aion: Mon 2026-01-12 06:00 to 20:00 UTC, 8 times"`` (the day once when the
    series stays in one day)."""
    from aion_cli.engine.time_text import from_ns
    from aion_cli.timeparse import resolve_zone

    first, last = times[0], times[-1]
    if len(times) == 1 or first is None or last is None:
        return name
    where = zone if zone is not None else resolve_zone("UTC")
    a, b = from_ns(first, where), from_ns(last, where)
    end = b.strftime("%H:%M" if a.date() == b.date() else "%a %Y-%m-%d %H:%M")
    return f"{name}: {a.strftime('%a %Y-%m-%d %H:%M')} to {end} {where.name}, {len(times)} times"


def path_label(t_ns: int | None) -> str:
    """The legend's name of the path drawn at ``t_ns``: planned against the flows forecast
    then, or, as observed (None, which has no time to forecast costs at), the shortest by
    distance (:func:`aion_cli.exports.planned_path`), which "planned path" had not said."""
    return "planned path" if t_ns is not None else "shortest path (by distance)"


def render_map_png(
    loaded: LoadedMap,
    t_ns: int | None,
    zone: Zone | None,
    out: Path,
    path_xyz: Any | None = None,
    *,
    title: str | None = None,
    dpi: float = DPI,
) -> Path:
    """The top-down picture of ``loaded`` at ``t_ns`` (None: as observed) as the PNG file
    ``out``, with the path ``path_xyz`` f64[p,3] if given; returns ``out``. A time whose hour
    no log observed is marked as :func:`export_png` marks it."""
    from aion_cli.formats.scene_colours import PATH_GREEN
    from aion_cli.scene import scene_at

    check_png_target(out)
    paths = []
    if path_xyz is not None:
        xyz = np.asarray(path_xyz, dtype=np.float64)
        paths = [PathLine(xyz, path_label(t_ns), PATH_GREEN)]
    fig = topdown_figure(
        [scene_at(loaded, t_ns)],
        _name_span(loaded, [t_ns], _mark_unobserved(loaded, [t_ns], [time_title(t_ns, zone)])),
        suptitle=title,
        paths=[paths],
        dpi=dpi,
        frame=map_frame(loaded),
    )
    return save_png(fig, out)


def export_png(
    loaded: LoadedMap,
    map_label: str,
    out: Path,
    times: Sequence[int | None],
    zone: Zone | None,
    ends: tuple[Any, int, int] | None = None,
    on_frame: Callable[[], None] | None = None,
    dpi: float = DPI,
    option: str = "-o",
) -> Path:
    """One PNG file ``out`` (named in errors as ``option``: the CLI's ``-o``, the API's
    ``file``, then naming the series ``step`` and ``series``): the map at one time, or small
    multiples of a series (one panel per time, at most
    :data:`~aion_cli.pictures.topdown.MAX_PANELS`, sharing axes, flow scale and colour bar),
    with the path planned between ``ends`` (from ``exports.path_ends``) at each time."""
    from aion_cli.engine.node_ids import node_label
    from aion_cli.exports import planned_path
    from aion_cli.formats.scene_colours import PATH_GREEN
    from aion_cli.pictures.plan import end_markers
    from aion_cli.scene import scene_at

    check_png_target(out, option)
    if len(times) > MAX_PANELS:
        raise InputError(
            f"the picture would have {len(times)} panels, more than {MAX_PANELS}",
            hint=_fitting_step_hint(times, cli=option == "-o"),
        )
    first = scene_at(loaded, times[0]) if times else None
    floors = len(levels_apart([first], MAX_PANELS)) if first is not None else 1
    if floors > 1 and len(times) * floors > MAX_PANELS:  # a panel per time and level
        raise InputError(
            f"the picture would have {len(times) * floors} panels ({len(times)} times on "
            f"{floors} levels), more than {MAX_PANELS}",
            hint=_fitting_step_hint(times, floors, cli=option == "-o"),
        )
    scenes = []
    paths: list[list[PathLine]] = []
    markers: list[Marker] = []
    for k, t_ns in enumerate(times):
        scenes.append(first if k == 0 and first is not None else scene_at(loaded, t_ns))
        if ends is not None:
            xyz = np.asarray(planned_path(loaded, t_ns, ends), dtype=np.float64)
            paths.append([PathLine(xyz, path_label(t_ns), PATH_GREEN)])
            # which end is which (the path is planned from one to the other, against the
            # flows it meets): the green line alone did not say
            markers = markers or end_markers(xyz, node_label(ends[1]), node_label(ends[2]))
        else:
            paths.append([])
        if on_frame is not None:
            on_frame()
    titles = [time_title(times[0], zone)] if len(times) == 1 else _panel_titles(times, zone)
    titles = _name_span(loaded, times, _mark_unobserved(loaded, times, titles))
    fig = topdown_figure(
        scenes,
        titles,
        suptitle=_series_title(map_label, times, zone),
        paths=paths,
        markers=markers,
        dpi=dpi,
        frame=map_frame(loaded),
    )
    return save_png(fig, out, option)


_NICE_STEPS_S = (60, 300, 600, 900, 1200, 1800, 3600, 7200, 10800, 14400, 21600, 43200,
                 86400, 172800, 604800)


def _fitting_step_hint(times: Sequence[int | None], per_time: int = 1, cli: bool = True) -> str:
    """The hint for a series of too many panels: the smallest round ``--step`` that draws
    the same span in at most :data:`MAX_PANELS` panels (``per_time`` panels a time: the
    levels of a multi-storey map); ``cli`` False: in the API's words (``step``, ``series``)."""
    known = [t for t in times if t is not None]
    span_s = (max(known) - min(known)) / 1e9 if known else 0.0
    for step in _NICE_STEPS_S:
        panels = (int(span_s // step) + 1) * per_time
        if panels <= MAX_PANELS:
            unit = (
                f"{step // 86400}d" if step % 86400 == 0
                else f"{step // 3600}h" if step % 3600 == 0
                else f"{step // 60}m"
            )
            step_is, span = (
                (f"--step {unit}", "--from/--to") if cli else (f'step="{unit}"', "series")
            )
            return f"{step_is} draws this span in {panels} panels (or shorten {span})"
    return "use a larger --step (or a shorter --from/--to)" if cli else (
        "use a larger step (or a shorter series)"
    )


def plan_png(
    loaded: LoadedMap,
    routes: Routes,
    nav: Any,
    zone: Zone,
    out: Path,
    dpi: float = DPI,
    ends: tuple[str, str] | None = None,
    observed: bool | None = None,
) -> Path:
    """The picture of ``aion plan``'s two routes (from ``routes.plan_routes``) over the flow
    map at the departure, as the PNG file ``out`` (``--png``); ``ends``: how the start and
    goal are named (``kitchen (p117)``; default: their place ids). ``observed`` False (the
    departure's hour no day observed: ``hour_observed``) adds the table's mark,
    :data:`~aion_cli.note_words.EXTRAPOLATED`, under the title, as the costs in the
    legend come from extrapolated flows; a departure far from the map's data says how far
    (:func:`_name_span`)."""
    from aion_cli.engine.node_ids import node_label
    from aion_cli.note_words import EXTRAPOLATED
    from aion_cli.pictures.plan import DrawnRoute, plan_figure
    from aion_cli.scene import scene_at

    check_png_target(out, "--png")

    def drawn(route: Any) -> DrawnRoute:
        return DrawnRoute(
            np.asarray(nav.xyz, dtype=np.float64)[route.rows], route.length_m, route.cost
        )

    start, goal = ends or (node_label(routes.start), node_label(routes.goal))
    title = f"{start} to {goal}, departing {time_title(routes.depart_ns, zone)}"
    if observed is False:  # a line of its own: the panel's title is not wrapped
        title += f"\n{EXTRAPOLATED}"
    (title,) = _name_span(loaded, [routes.depart_ns], [title])  # a departure far from the data
    fig = plan_figure(
        scene_at(loaded, routes.depart_ns),
        drawn(routes.temporal),
        drawn(routes.distance_only),
        start_label=start,
        goal_label=goal,
        title=title,
        dpi=dpi,
        frame=map_frame(loaded),
    )
    return save_png(fig, out, "--png")
