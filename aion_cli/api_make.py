"""The Python API's functions that make maps: :func:`build` (``aion build``), :func:`merge`
(``aion merge``) and :func:`compact` (``aion compact``). Each returns the :class:`aion_cli.api.Map`
it wrote, with what was done in ``Map.report``; :mod:`aion_cli.api` re-exports them.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Union

from aion_cli.errors import InputError

if TYPE_CHECKING:
    from aion_cli.api import Map, TimeLike
    from aion_cli.build_report import ProgressSink
    from aion_cli.engine.config import ModelConfig

PathLike = Union[str, "os.PathLike[str]"]


def as_path(value: PathLike) -> Path:
    """A path argument as a ``Path``; an empty one is an ``InputError`` (``Path("")`` is the
    current folder: an unset variable must not mean "here", as on the command line)."""
    text = os.fspath(value)
    if not str(text).strip():
        raise InputError("an empty path was given", hint="name the file or folder ('.' for here)")
    return Path(text)


def build(
    logs: PathLike | Sequence[PathLike],
    output: PathLike | None = None,
    *,
    continue_from: PathLike | None = None,
    config: ModelConfig | None = None,
    graph: PathLike | None = None,
    tz: str | None = None,
    detection_topics: Sequence[str] = (),
    graph_topic: str | None = None,
    map_frame: str | None = None,
    base_frame: str = "base_link",
    derive_graph: bool = False,
    nav_layer: str | None = None,
    detections_mapping: PathLike | None = None,
    log_format: str | None = None,
    workers: int = 1,
    scheduler: str | None = None,
    part: bool = False,
    observed: Sequence[tuple[TimeLike, TimeLike]] = (),
    progress: ProgressSink | None = None,
) -> Map:
    """Build a map from logs (or extend ``continue_from`` with them) and write it to
    ``output`` (default: the first log's name with ``.aion``), as ``aion build``; the map,
    with what the build did in ``Map.report``. ``workers`` / ``scheduler`` / ``part``: as
    ``aion build --workers`` (0: one per core; worker processes fork from this one, so a
    script that builds with workers needs the usual ``if __name__ == "__main__":`` guard on
    platforms without ``fork``), ``--scheduler`` and ``--part``. ``observed``: ``(start,
    end)`` spans a fixed sensor was recording, as ``--observed`` (times as in
    ``Map.predict``, naive ones in ``tz``, else UTC)."""
    from aion_cli.api import Map, to_ns
    from aion_cli.build_options import map_frame_of
    from aion_cli.pipeline import BuildOptions, build_map
    from aion_cli.timeparse import resolve_zone

    paths = [logs] if isinstance(logs, (str, os.PathLike)) else list(logs)
    spans: tuple[tuple[int, int], ...] = ()
    if observed:  # (a build without spans reads ``tz`` as before, in the build)
        zone = resolve_zone(tz or "UTC")
        spans = tuple((to_ns(a, zone), to_ns(b, zone)) for a, b in observed)
    for (a, b), (ta, tb) in zip(spans, observed, strict=True):
        if b <= a:
            raise InputError(f"observed span {ta!r}..{tb!r}: the end is not after the start")

    def opt(p: PathLike | None) -> Path | None:
        return None if p is None else as_path(p)

    opts = BuildOptions(
        logs=tuple(as_path(p) for p in paths),
        output=opt(output),
        config=config,
        log_format=log_format,
        detection_topics=tuple(detection_topics),
        graph_topic=graph_topic,
        map_frame=map_frame_of(map_frame, opt(continue_from)),
        base_frame=base_frame,
        graph_file=opt(graph),
        nav_layer=nav_layer,
        derive_graph=derive_graph,
        continue_from=opt(continue_from),
        timezone=tz,
        detections_mapping=opt(detections_mapping),
        workers=workers,
        scheduler=scheduler,
        part=part,
        observed=spans,
    )
    report = build_map(opts, progress)
    made = Map.load(report.output)
    made.report = report
    return made


def merge(
    paths: Sequence[PathLike],
    output: PathLike,
    *,
    graph: PathLike | None = None,
    lineage: str = "auto",
    nav_layer: str | None = None,
    progress: ProgressSink | None = None,
) -> Map:
    """Merge map files of disjoint time into ``output``, as ``aion merge``
    (:func:`aion_cli.merging.merge_map_files`: same model parameters, no log in two maps,
    ``lineage`` auto / same / different, ``graph`` a Hydra graph file to bind to; one part
    map alone, ``aion build --part``, is made a map); the merged map, with what the merge did
    in ``Map.report`` (a ``MergeReport``)."""
    from aion_cli.api import Map
    from aion_cli.merging import merge_map_files

    if isinstance(paths, (str, os.PathLike)):
        raise InputError("merge takes a list of map files", hint="merge([a, b], output)")
    report = merge_map_files(
        [as_path(p) for p in paths],
        as_path(output),
        None if graph is None else as_path(graph),
        lineage,
        progress,
        nav_layer,
    )
    made = Map.load(report.output)
    made.report = report
    return made


def compact(source: PathLike, output: PathLike) -> Map:
    """Write the query-only copy of the map ``source`` to ``output``, as ``aion compact``
    (:func:`aion_cli.query_only.compact_map`: the same answers to every query, without the
    Fourier sums that continuing and merging need); the copy, with what was done in
    ``Map.report`` (a ``CompactReport``)."""
    from aion_cli.api import Map
    from aion_cli.query_only import compact_map

    report = compact_map(as_path(source), as_path(output))
    made = Map.load(report.output)
    made.report = report
    return made
