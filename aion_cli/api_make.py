"""The Python API's functions that make maps: :func:`build` (``aion build``), :func:`merge`
(``aion merge``) and :func:`compact` (``aion compact``). Each returns the :class:`aion_cli.api.Map`
it wrote, with what was done in ``Map.report``; :mod:`aion_cli.api` re-exports them. Beside
them ``Map.holdout``'s scoring (:func:`score_holdout`); the map :meth:`Map.from_state` makes
of a state in memory and the two ways ``Map.save`` writes a map are in :mod:`aion_cli.api_state`.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, Union

from aion_cli.api_checks import (
    CountLike,
    SpansLike,
    StepLike,
    ZoneLike,
)
from aion_cli.api_keywords import keywords_checked, refuse_unknown_keywords
from aion_cli.errors import InputError

if TYPE_CHECKING:
    from aion_cli.api import Map
    from aion_cli.build_options import BuildOptions
    from aion_cli.build_report import BuildReport, ProgressSink
    from aion_cli.engine.config import ModelConfig
    from aion_cli.evaluation.holdout import HoldoutResult
    from aion_cli.manifest import Manifest
    from aion_cli.mapquery import LoadedMap
    from aion_cli.merging import MergeReport
    from aion_cli.query_only import CompactReport

PathLike = Union[str, "os.PathLike[str]"]


def as_path(value: PathLike, what: str = "path") -> Path:
    """A path argument as a ``Path``; an empty one is an ``InputError`` (``Path("")`` is the
    current folder: an unset variable must not mean "here", as on the command line), and so
    is anything but ``str`` or ``os.PathLike``."""
    from aion_cli.api_checks import path_text

    text = path_text(value, what)
    if not text.strip():
        raise InputError("an empty path was given", hint="name the file or folder ('.' for here)")
    head = next(iter(Path(text).parts), "")  # "." has no parts
    if head.startswith("~") and not os.path.lexists(head):  # "~/logs/run.mcap" from a shell
        raise InputError(
            f"{what} {text!r} starts with {head!r}, which Python does not expand as a shell does "
            f"(nor is there a file or folder {head!r} in the current folder)",
            hint=f"give os.path.expanduser({text!r}), i.e. {os.path.expanduser(text)!r}",
        )
    return Path(text)


def warn_of(warnings: list[str], notes: list[str]) -> None:
    """Each of a report's warnings as an :class:`~aion_cli.errors.AionWarning` (the CLI
    prints them as ``warning: ...``; a script would not see them in ``report.warnings``),
    pointing at the line that called the API: the first frame outside the package, however
    many of its wrappers (argument checks, one query at a time) lie between. The warnings
    name the API's keywords, not the command line's options
    (:func:`aion_cli.api_words.api_text`: ``observed= ignored``, not ``--observed
    ignored``), and are rewritten so in ``warnings`` itself (the report's list), and so are
    its ``notes`` (not issued: the CLI prints them only without ``-q``)."""
    import sys
    import warnings as python_warnings
    from pathlib import Path

    from aion_cli.api_words import api_text
    from aion_cli.errors import AionWarning

    warnings[:] = [api_text(text) for text in warnings]
    notes[:] = [api_text(text) for text in notes]

    package = str(Path(__file__).resolve().parent) + "/"
    level, frame = 1, sys._getframe(0)
    while frame.f_back is not None and str(Path(frame.f_code.co_filename).resolve()).startswith(
        package
    ):
        frame, level = frame.f_back, level + 1
    for text in warnings:
        python_warnings.warn(text, AionWarning, stacklevel=level)


class Progress(Protocol):
    """What ``progress=`` of :func:`build` and :func:`merge` takes: ``start(description,
    total, unit)`` at each phase (``total`` of ``unit``: "msgs", "MiB", "maps", "shards"),
    then ``advance(n)`` as ``n`` more are done."""

    def start(self, description: str, total: int, unit: str) -> None: ...

    def advance(self, n: int) -> None: ...


class _EveryUnit:
    """A caller's :class:`Progress` as the build's ``ProgressSink``: ``start`` always given
    the unit (the build's phases leave "msgs" to the sink's default, which a caller's
    ``start(description, total, unit)`` need not have)."""

    def __init__(self, progress: Progress) -> None:
        self._progress = progress

    def start(self, description: str, total: int, unit: str = "msgs") -> None:
        self._progress.start(description, total, unit)

    def advance(self, n: int) -> None:
        self._progress.advance(n)


def progress_sink(progress: object) -> ProgressSink | None:
    """``progress`` checked: None, or an object with the ``start(description, total,
    unit)`` and ``advance(n)`` methods of :class:`Progress`, the type the docs name (not
    a flag: a build calls them, and would fail deep inside on anything else)."""
    if progress is None:
        return None
    if not all(callable(getattr(progress, name, None)) for name in ("start", "advance")):
        raise InputError(
            f"progress must have start(description, total, unit) and advance(n) methods, "
            f"got {progress!r}",
            hint="leave it out, or pass an object with those methods "
            "(the protocol aion_cli.api_make.Progress)",
        )
    return _EveryUnit(progress)  # type: ignore[arg-type]


@keywords_checked
def build(
    logs: PathLike | Iterable[PathLike],
    output: PathLike | None = None,
    *,
    continue_from: PathLike | None = None,
    config: ModelConfig | Mapping[str, Any] | None = None,
    graph: PathLike | None = None,
    lineage: str = "auto",
    tz: ZoneLike | None = None,
    detection_topics: Sequence[str] = (),
    graph_topic: str | None = None,
    map_frame: str | None = None,
    base_frame: str = "base_link",
    derive_graph: bool = False,
    nav_layer: str | None = None,
    detections_mapping: PathLike | None = None,
    log_format: str | None = None,
    workers: CountLike = 1,
    scheduler: str | None = None,
    part: bool = False,
    observed: SpansLike = (),
    graph_period: StepLike | None = None,
    dsg_version: str | None = None,
    batch_size: CountLike = 4000,
    progress: Progress | None = None,
) -> Map[BuildReport]:
    """Build a map from logs (or extend ``continue_from`` with them) and write it to
    ``output`` (default: the first log's name with ``.aion``), as ``aion build``; the map,
    with what the build did in ``Map.report``. ``workers`` / ``scheduler`` / ``part``: as
    ``aion build --workers`` (0: one per core; worker processes fork from this one, so a
    script that builds with workers needs the usual ``if __name__ == "__main__":`` guard on
    platforms without ``fork``), ``--scheduler`` and ``--part``. ``observed``: ``(start,
    end)`` spans a fixed sensor was recording, as ``--observed`` (times as in
    ``Map.predict``; naive ones in the zone the map follows: ``tz``, else ``continue_from``'s
    zone, else the zone the logs declare, else UTC). Without ``tz`` a new map follows the
    zone its logs declare (``aion simulate --tz`` writes it into its logs), with a note in
    ``Map.report``; a ``tz`` that differs from it is a warning. ``graph_period``: about one
    scene graph per period of log time (``"5s"``, ``"1m"``, seconds, a ``timedelta`` or a
    ``numpy.timedelta64``; 0:
    every graph; None: 5 s), as ``--graph-period``; ``dsg_version`` (``"1.1.3"``) and
    ``batch_size`` (detection messages decoded per chunk; another size
    may change the map's sums in their last bits) as ``--dsg-version`` and ``--batch-size``.
    ``lineage`` (auto / same / different): whether ``graph``, else the logs' first scene
    graph, is of ``continue_from``'s scene-graph session, as ``--lineage``."""
    from aion_cli.api import read_map
    from aion_cli.api_checks import count, flag, path_list, text, zone_name
    from aion_cli.build_options import map_frame_of
    from aion_cli.log_zone import build_zone, continued_zone
    from aion_cli.pipeline import build_map
    from aion_cli.timeparse import resolve_zone

    paths = path_list(logs, "logs")  # read twice below: a generator of logs only once
    tz = zone_name(tz)
    if tz is not None:  # named as aion build --tz names it: UTC+05:30, the machine's for local
        tz = resolve_zone(tz).name
    continued = _optional_path(continue_from, "continue_from")
    reading: dict[str, object] = {
        "log_format": log_format,
        "detection_topics": detection_topics,
        "graph_topic": graph_topic,
        "base_frame": base_frame,
        "detections_mapping": detections_mapping,
        "observed": observed,
    }
    map_zone = continued_zone(continued)
    opts = reading_options(paths, dict(reading, observed=()), tz)  # the logs, for their zone
    # the zone the logs declare (aion simulate --tz), as aion build takes it
    tz, notes, warnings = build_zone(tz, map_zone, opts.logs)
    # observed= read in the zone the map follows, as aion build reads --observed
    opts = reading_options(paths, reading, tz if tz is not None else map_zone)
    opts = replace(
        opts,
        output=_optional_path(output, "output"),
        config=_config(config),
        map_frame=map_frame_of(text(map_frame, "map_frame"), continued),
        graph_file=_optional_path(graph, "graph"),
        nav_layer=text(nav_layer, "nav_layer"),
        derive_graph=flag(derive_graph, "derive_graph"),
        continue_from=continued,
        lineage=text(lineage, "lineage") or "auto",
        timezone=tz,
        workers=count(workers, "workers", minimum=0) or 0,
        scheduler=text(scheduler, "scheduler"),
        part=flag(part, "part"),
        graph_period_ns=_period_ns(graph_period),
        dsg_version=text(dsg_version, "dsg_version"),
        batch_size=count(batch_size, "batch_size") or 1,
    )
    report = build_map(opts, progress_sink(progress))
    report.notes[:0] = notes
    report.warnings[:0] = warnings
    warn_of(report.warnings, report.notes)
    return read_map(report.output, report)


@keywords_checked
def merge(
    paths: Iterable[PathLike],
    output: PathLike,
    *,
    graph: PathLike | None = None,
    lineage: str = "auto",
    nav_layer: str | None = None,
    progress: Progress | None = None,
) -> Map[MergeReport]:
    """Merge map files of disjoint time into ``output``, as ``aion merge``
    (:func:`aion_cli.merging.merge_map_files`: same model parameters, no log in two maps,
    ``lineage`` auto / same / different, ``graph`` a Hydra graph file to bind to; one part
    map alone, ``aion build --part``, is made a map, given alone or in a list, as
    :func:`build` takes one log); the merged map, with what the merge did
    in ``Map.report`` (a ``MergeReport``)."""
    from aion_cli.api import read_map
    from aion_cli.api_checks import path_list, text
    from aion_cli.merging import merge_map_files

    if isinstance(paths, (str, os.PathLike)):  # one path alone, as build takes one log
        paths = [paths]
    report = merge_map_files(
        [as_path(p, "map") for p in path_list(paths, "paths", one=False)],  # type: ignore[arg-type]
        as_path(output),
        None if graph is None else as_path(graph),
        lineage,
        progress_sink(progress),
        text(nav_layer, "nav_layer"),
    )
    warn_of(report.warnings, report.notes)
    return read_map(report.output, report)


@keywords_checked
def compact(source: PathLike, output: PathLike) -> Map[CompactReport]:
    """Write the query-only copy of the map ``source`` to ``output``, as ``aion compact``
    (:func:`aion_cli.query_only.compact_map`: the same answers to every query, without the
    Fourier sums that continuing and merging need); the copy, with what was done in
    ``Map.report`` (a ``CompactReport``)."""
    from aion_cli.api import read_map
    from aion_cli.query_only import compact_map

    report = compact_map(as_path(source), as_path(output))
    return read_map(report.output, report)


READING = (
    "log_format", "detection_topics", "graph_topic", "map_frame", "base_frame",
    "detections_mapping", "observed",
)  # fmt: skip
"""How logs are read, the options :meth:`aion_cli.api.Map.holdout` shares with :func:`build`."""


def reading_options(
    logs: object, options: dict[str, object], tz: str | None, where: str = "build"
) -> BuildOptions:
    """The ``BuildOptions`` that read ``logs`` as :func:`build` reads them, from the reading
    ``options`` (:data:`READING`; others are an ``InputError`` naming the ones there are):
    one topic given alone is one topic, ``observed`` spans are times as in ``Map.predict``
    (naive ones in ``tz``, else UTC), paths ``str`` or ``os.PathLike``."""
    from aion_cli.api import to_ns
    from aion_cli.api_checks import path_list, text
    from aion_cli.api_checks import spans as span_pairs
    from aion_cli.build_options import map_frame_of
    from aion_cli.pipeline import BuildOptions
    from aion_cli.timeparse import resolve_zone

    refuse_unknown_keywords(where, options, ("radius", *READING) if "." in where else READING)
    paths = path_list(logs, "logs")
    if not paths:
        raise InputError("no log given", hint="pass at least one log file or folder")
    topics = options.get("detection_topics") or ()
    if isinstance(topics, str):
        topics = (topics,)
    if not isinstance(topics, Sequence) or not all(isinstance(t, str) for t in topics):
        raise InputError(
            f"detection_topics must be topic names, got {topics!r}",
            hint='e.g. detection_topics=["/people"] (aion info LOG lists the topics)',
        )
    given = span_pairs(options.get("observed"))
    spans: tuple[tuple[int, int], ...] = ()
    if given:  # (a build without spans reads ``tz`` as before, in the build)
        zone = resolve_zone(tz or "UTC")
        spans = tuple((to_ns(a, zone), to_ns(b, zone)) for a, b in given)
    for (a, b), (ta, tb) in zip(spans, given, strict=True):
        if b <= a:
            raise InputError(
                f"observed span {ta!r}..{tb!r}: the end is not after the start",
                hint="give each span as (start, end) with end later than start"
                + (": a span observed lasts, and (T, T) is one instant (only Map.plan's leave "
                   "takes it, as the one departure T)" if a == b else ""),
            )  # fmt: skip
    fields: dict[str, object] = {
        "log_format": text(options.get("log_format"), "log_format"),
        "detection_topics": tuple(str(t) for t in topics),
        "graph_topic": text(options.get("graph_topic"), "graph_topic"),
        "base_frame": text(options.get("base_frame"), "base_frame") or "base_link",
        "detections_mapping": _optional_path(options.get("detections_mapping"), "mapping"),
        "observed": spans,
        # as given, for the warning on a span apart from the logs (aion_cli.times_apart)
        "observed_typed": tuple(
            (f"{ta}..{tb}", span) for (ta, tb), span in zip(given, spans, strict=True)
        ),
    }
    frame = text(options.get("map_frame"), "map_frame")
    if frame is not None:  # spelt as the logs' frames are (/map is map), as --map-frame is
        fields["map_frame"] = map_frame_of(frame, None)
    return BuildOptions(logs=tuple(as_path(p, "log") for p in paths), **fields)  # type: ignore[arg-type]


def _period_ns(value: object) -> int:
    """``graph_period`` as ``--graph-period`` reads it, in ns: text (``"5s"``, ``"1m30s"``),
    seconds (0: every graph), a ``timedelta`` or a ``numpy.timedelta64`` (its duration, as a
    series ``step``'s: numpy's is an integer to ``numbers``, whose count of units was read as
    seconds, or refused by ``float``); None is the build's default (5 s)."""
    from aion_cli.api_checks import step
    from aion_cli.graph_schedule import DEFAULT_GRAPH_PERIOD_NS, parse_period_ns

    if value is None:
        return DEFAULT_GRAPH_PERIOD_NS
    seconds = step(value, "graph_period")
    if isinstance(seconds, str):
        return parse_period_ns(seconds)
    if seconds < 0:
        raise InputError(
            f"graph_period must be 0 or more seconds, got {value!r}",
            hint='e.g. graph_period="5s", 60 or 0 (every graph)',
        )
    from decimal import Decimal

    return parse_period_ns(f"{Decimal(repr(seconds)):f}")  # exact, as the text would be


def _optional_path(value: object, what: str) -> Path | None:
    return None if value is None else as_path(value, what)  # type: ignore[arg-type]


def _config(config: object) -> ModelConfig | None:
    """``ModelConfig``, a dict of its parameters (as ``--config``'s TOML), or None."""
    from aion_cli.engine.config import ModelConfig

    if config is None or isinstance(config, ModelConfig):
        return config
    if isinstance(config, Mapping):
        return ModelConfig.from_dict(dict(config))
    raise InputError(
        f"config must be a ModelConfig or a dict of its parameters, got {config!r}",
        hint="aion_cli.engine.config.ModelConfig(...), or e.g. {\"bins\": 8}",
    )


def score_holdout(
    loaded: LoadedMap,
    manifest: Manifest,
    timezone: str | None,
    logs: object,
    radius: float,
    options: dict[str, object],
) -> HoldoutResult:
    """``Map.holdout``: the map ``loaded`` scored on ``logs`` read with the build's reading
    ``options`` (``map_frame`` by default the frame the map records, else ``map``), its
    warnings issued as :class:`~aion_cli.errors.AionWarning` in the API's words."""
    from aion_cli.build_options import DEFAULT_MAP_FRAME
    from aion_cli.evaluation.holdout import score_held_out

    frame = options.pop("map_frame", None)  # a wrong type is refused with the options
    options["map_frame"] = (
        frame if frame is not None else manifest.map_frame or DEFAULT_MAP_FRAME
    )
    opts = reading_options(logs, options, timezone, "Map.holdout")
    result = score_held_out(loaded, opts, radius)
    warn_of(result.warnings, result.notes)
    return result
