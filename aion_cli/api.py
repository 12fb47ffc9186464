"""The Python API: build, load, query, plan, export and save maps without the command line.

    import aion_cli as aion
    m = aion.build(["run.mcap"], output="office.aion")   # -> aion.Map
    t = m.predict("2026-11-23 08:30")                    # -> aion.Table
    t.records()                                          # dicts, as predict --format json
    p = m.plan("p12", "p87", time="2026-11-23 08:30")    # -> aion.Plan (+ .distance_only)
    m.export("out/", time="2026-11-23 08:30")
    m.picture("map.png", time="2026-11-23 08:30")       # the map from above, as PNG
    m.save("copy.aion")

Paths are ``str`` or ``os.PathLike``. Times are aion time strings (``"2026-11-23 08:30"``,
``"monday 08:30"``, ``"+2h"``, ``"now"``, ``"1700000000"``), a ``datetime`` (a pandas
``Timestamp`` too), a ``date`` (its midnight) or a ``numpy.datetime64`` (these and strings
without a zone are read in the query's ``tz``, else the map's zone; a ``datetime64`` has
none), or integer nanoseconds since 1970 (UTC). Errors are the typed errors
of :mod:`aion_cli.errors` (``InputError`` and its subclasses for bad input), exactly
as the CLI reports them. The CLI's ``predict``, ``plan`` and ``export`` are formatting over
the same functions (:mod:`aion_cli.predictions`, :mod:`aion_cli.routes`,
:mod:`aion_cli.exports`), so results are equal to their JSON output.

:class:`Map` is here (:func:`to_ns` in :mod:`aion_cli.api_time`, the readers of arguments in
:mod:`aion_cli.api_checks`, its :meth:`Map.plan` in :mod:`aion_cli.api_plan`); the functions
that make maps (:func:`build`, :func:`merge`, :func:`compact`) live in
:mod:`aion_cli.api_make` and the query results
:class:`Table` and :class:`Plan` in :mod:`aion_cli.api_results`; both are re-exported here, so
``from aion_cli.api import Map, Plan, Table, build, compact, merge, to_ns`` imports them, and
``aion_cli`` re-exports them with ``info`` (``aion info LOG``'s report, from
:mod:`aion_cli.api_info`), ``SeriesTable``, ``AionError``, ``InputError``, ``AionWarning``
and the types of the other results, each by the name its repr gives (``BuildReport``,
``MergeReport``, ``CompactReport``, ``HoldoutResult``, ``Manifest``).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, Union, overload

from aion_cli import api_checks as check
from aion_cli import api_plan
from aion_cli.api_checks import (
    CountLike,
    NodesLike,
    PairOf,
    PlaceLike,
    PointLike,
    StepLike,
    TimeLike,
    ZoneLike,
)
from aion_cli.api_keywords import methods_checked
from aion_cli.api_make import PathLike, as_path, build, compact, merge
from aion_cli.api_results import MEMORY, Files, Plan, Table
from aion_cli.api_time import query_time, query_times, query_zone, to_ns
from aion_cli.api_typing import Made, Report
from aion_cli.errors import InputError
from aion_cli.map_sharing import new_lock, one_at_a_time, pickled, unpickled
from aion_cli.map_source import MapSource
from aion_cli.pinned_file import PinnedFile

if TYPE_CHECKING:
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.state import MapState
    from aion_cli.engine.time_text import Zone
    from aion_cli.evaluation.holdout import HoldoutResult
    from aion_cli.manifest import Manifest
    from aion_cli.mapquery import LoadedMap
    from aion_cli.prediction_series import SeriesTable

Loaded = Union["LoadedMap", MapSource]
"""What a :class:`Map` is made around: a map read (or built in memory), or a file's source."""

__all__ = ["Map", "Plan", "Table", "TimeLike", "as_path", "build", "compact", "merge", "to_ns"]


def read_map(path: Path, report: Made) -> Map[Made]:
    """The map file ``path`` as the query commands read it (``load_map(...,
    forecast_only=True)``: without the per-entry Fourier sums only learning reads; its state
    on first use, :mod:`aion_cli.map_source`), with the ``report`` of what made it:
    :meth:`Map.load` and the maps :func:`build`, :func:`merge` and :func:`compact` return."""
    return Map(MapSource.of_file(path), path, report)


@methods_checked
class Map(Generic[Report]):
    """A 4D scene-graph map: loaded from a ``.aion`` file, built from logs, or made from an
    in-memory ``MapState`` (:meth:`from_state`). Typed by what made it, its :attr:`report`:
    ``Map[BuildReport]`` from :func:`build`, ``Map[MergeReport]`` from :func:`merge`,
    ``Map[CompactReport]`` from :func:`compact`, ``Map[None]`` from :meth:`load` and
    :meth:`from_state`; a bare ``Map`` is any of them."""

    @overload
    def __init__(self: Map[None], loaded: Loaded, path: Path | None = None) -> None: ...
    @overload
    def __init__(self, loaded: Loaded, path: Path | None, report: Report) -> None: ...
    def __init__(self, loaded: Loaded, path: Path | None = None, report: Any = None) -> None:
        from aion_cli.mapquery import LoadedMap

        if not isinstance(loaded, LoadedMap | MapSource):  # Map("office.aion"): a path
            raise InputError(
                f"Map() takes a loaded map, got {type(loaded).__name__}",
                hint="read a file with aion.Map.load(path)",
            )
        self._source = loaded if isinstance(loaded, MapSource) else MapSource.ready(loaded)
        self.path = path
        self._report = report
        self._file: PinnedFile | None = None if path is None else PinnedFile(path)
        self._lock = new_lock()  # one query at a time (aion_cli.map_sharing)

    @property
    def _loaded(self) -> LoadedMap:
        with self._lock:  # a file's state is read on first use (aion_cli.map_source)
            return self._source.get(self._file)

    @property
    def report(self) -> Report:
        """What the build (:func:`build`), the merge (:func:`merge`) or :func:`compact` did
        (None for a map from :meth:`load` or :meth:`from_state`)."""
        return self._report

    @classmethod
    def load(cls, path: PathLike) -> Map[None]:
        """Read a map file's manifest (version checked) now and its state on first use
        (:mod:`aion_cli.map_source`; each member checksummed as it is read), as the
        query commands read it: without the per-entry Fourier sums only learning reads
        (``load_map(..., forecast_only=True)``; :mod:`aion_cli.query_only`), so every answer
        is the command line's and a big map takes the memory of its forecasts, not of its
        learning (the sums are most of a full map's bytes)."""
        return read_map(as_path(path), None)

    @classmethod
    def from_state(cls, state: MapState, timezone: ZoneLike | None = None) -> Map[None]:
        """A map around a state built in memory (``engine.mapper.Mapper(...).state``), e.g. to
        :meth:`save` it; its scene graph and manifest (its queries' notes; its time span, the log
        times fed: :func:`aion_cli.api_state.state_span`) are the state's now: wrap it again after
        feeding more. A fixed sensor's windows after its last detection count as observed, as
        ``aion build`` of its log counts them: the map is then of a copy advanced to its
        intervals' end (:func:`aion_cli.api_state.observed_to_end`), the Mapper's state left
        as it was. A loaded map's state is refused: its queries count its pending day and
        open window as closed, in place (:meth:`save` copies a loaded map)."""
        from aion_cli.api_state import state_map

        return Map(state_map(state, timezone))

    # -- what the map is ---------------------------------------------------------------------

    @property
    def config(self) -> ModelConfig:
        """The model parameters the map was built with (a file's from its manifest, its state
        not read for them, as ``aion info``)."""
        from aion_cli.engine.state_checks import parse_state_meta

        if self._source.loaded is None:  # the manifest's, which the state is made with
            return parse_state_meta(self._source.manifest["state"]).config
        return self._loaded.config

    @property
    def state(self) -> MapState:
        """The engine state (entries, temporal model, ownership); see ``aion_cli.engine``."""
        return self._loaded.state

    @property
    def manifest(self) -> Manifest:
        """What the map file says about itself: inputs, time span, counts, zone, families."""
        from aion_cli.manifest import Manifest

        raw = dict(self._source.manifest)
        raw.setdefault("state", {})
        return Manifest.from_dict(raw)

    @property
    def timezone(self) -> str | None:
        """The zone the map was built for (``aion build --tz``), the default of queries."""
        zone = self._source.manifest.get("timezone")
        return zone if isinstance(zone, str) else None

    @property
    def _label(self) -> str:
        """The map's name in its results and repr: its path, else ``"<memory>"`` (MEMORY)."""
        return str(self.path) if self.path is not None else MEMORY

    def _zone(self, tz: object) -> Zone:
        """``tz``, else the map's zone (:func:`aion_cli.api_time.query_zone`)."""
        return query_zone(tz, self.timezone)

    def _time(
        self, time: TimeLike, tz: object, after_ns: int | None = None
    ) -> tuple[int, Zone]:
        """``time`` in ``tz``, else the map's zone (:func:`aion_cli.api_time.query_time`)."""
        return query_time(time, tz, self.timezone, after_ns)

    def _path_ends(self, path: object) -> Any:
        """The ends of ``path = (start, goal)`` for an export or a picture (None: no path)."""
        from aion_cli.exports import path_ends

        if path is None:
            return None
        a, b = check.pair(path, "path", "start, goal")
        a, b = check.endpoint(a, "path"), check.endpoint(b, "path")
        return path_ends(self._loaded, str(a), str(b))

    def _check_file(self) -> None:
        """:class:`MapFileError` when the file this map was loaded from was overwritten in
        place since (its members would be read from the new bytes, or past its end)."""
        if self._file is not None:
            self._file.check()

    def _notes(
        self, time: object, zone: Zone, t_ns: int, series: list[int] | None = None,
        noun: str = "times",
    ) -> list[str]:
        """:func:`aion_cli.forecast_notes.query_notes` of this map, in the API's words."""
        from aion_cli.api_words import api_text
        from aion_cli.forecast_notes import query_notes

        return [api_text(n) for n in query_notes(self.manifest, time, zone, t_ns, series, noun)]

    def _flowless(self, kinds: Any) -> tuple[str, ...]:
        """:func:`aion_cli.api_results.flowless_rows_note` of rows of kinds ``kinds``, in the
        API's words (none, or one note)."""
        from aion_cli.api_results import flowless_rows_note
        from aion_cli.api_words import api_text

        said = flowless_rows_note(self._loaded.state, kinds)
        return () if said is None else (api_text(said),)

    # -- queries -----------------------------------------------------------------------------

    @one_at_a_time
    def predict(
        self,
        time: TimeLike | None = None,
        *,
        historical: bool = False,
        tz: ZoneLike | None = None,
        layer: str = "all",
        nodes: NodesLike | None = None,
        at: PointLike | None = None,
        top: CountLike | None = None,
    ) -> Table:
        """Flows per entry at ``time`` (default now; ``historical=True``: as observed), as
        ``aion predict`` with ``--layer``, ``--node`` (``nodes``: ids, or one id), ``--at``
        (``"x,y"`` or numbers) and ``--top``."""
        from aion_cli.engine.time_text import format_ns
        from aion_cli.predictions import LAYERS, hour_flags, predicted_records

        if layer not in LAYERS:
            raise InputError(f"unknown layer {layer!r}", hint=f"one of {', '.join(LAYERS)}")
        historical = check.historical(time, historical)
        wanted, point, top = check.selection(nodes, at, top)
        self._check_file()
        t_ns: int | None = None
        zone = None
        if not historical:
            t_ns, zone = self._time("now" if time is None else time, tz)
        rows, _ = predicted_records(self._loaded, t_ns, layer, wanted, point, top)
        notes = () if t_ns is None or zone is None else tuple(self._notes(time, zone, t_ns))
        notes += self._flowless([row["kind"] for row in rows])
        return Table(
            self._label,
            t_ns,
            None if t_ns is None or zone is None else format_ns(t_ns, zone),
            None if zone is None else zone.name,
            int(self.config.bins),
            tuple(rows),
            hour_flags(self._loaded, [t_ns])[0],
            notes,
        )

    @one_at_a_time
    def predict_series(
        self,
        start: TimeLike,
        end: TimeLike,
        step: StepLike = "1h",
        *,
        tz: ZoneLike | None = None,
        layer: str = "all",
        nodes: NodesLike | None = None,
        at: PointLike | None = None,
        top: CountLike | None = None,
    ) -> SeriesTable:
        """Predicted flow of the entries asked for at ``start``, ``start + step``, ... up to
        ``end`` inclusive (``step``: elapsed time as ``"1h"``, ``"30m"``, ``"1h30m"``,
        ``"600s"``, seconds, a ``timedelta`` or a ``numpy.timedelta64``; or ``"1d"`` / ``"1w"``:
        calendar days in ``tz``, the same wall-clock time every day across a daylight-saving
        change, where ``timedelta(days=1)`` is 24 h), as ``aion predict --from --to --step``:
        an :class:`aion_cli.prediction_series.SeriesTable` (``flow`` and ``flow_per_hour`` as
        arrays entries x times; ``records()`` as its JSON's entries, ``to_dict()`` as the whole
        document, with ``times``, ``zone`` and ``hour_observed``); each value equals
        :meth:`predict` at that time."""
        from dataclasses import replace

        from aion_cli.engine.time_text import format_ns
        from aion_cli.prediction_series import described, predict_series, series_times
        from aion_cli.predictions import LAYERS, hour_flags
        from aion_cli.time_steps import parse_step

        if layer not in LAYERS:
            raise InputError(f"unknown layer {layer!r}", hint=f"one of {', '.join(LAYERS)}")
        wanted, point, top = check.selection(nodes, at, top)
        self._check_file()
        every = parse_step(check.step(step), "step")
        t0, zone = self._time(start, tz)
        t1, _ = self._time(end, tz, after_ns=t0)
        times = series_times(t0, t1, every, zone, ("start", "end"), typed=start)
        table = predict_series(self._loaded, times, layer, wanted, point, top)
        labels = [format_ns(t, zone) for t in times]
        made = described(table, self._label, zone, labels, hour_flags(self._loaded, times))
        kinds = [e["kind"] for e in table.entries] if table.columns is None else (
            table.columns.column("kind")
        )
        notes = (*self._notes(start, zone, times[0], times), *self._flowless(kinds))
        return replace(made, notes=notes)

    plan = api_plan.plan  # a path, or the best departure (aion_cli.api_plan)

    @one_at_a_time
    def export(
        self,
        folder: PathLike,
        *,
        time: TimeLike | None = None,
        historical: bool = False,
        tz: ZoneLike | None = None,
        format: str | None = None,
        path: PairOf[PlaceLike] | None = None,
        force: bool = False,
        series: PairOf[TimeLike] | None = None,
        step: StepLike | None = None,
    ) -> Files:
        """Write the scene (PLY or PCD) and ``entries.csv`` / ``entries.json`` at ``time``
        (or as observed) into ``folder``, optionally with the path planned between
        ``path = (start, goal)``; the files written (as ``aion export``). ``format="mcap"``
        writes the scene as the one MCAP file ``folder`` names (``scene.mcap``, for Foxglove
        and RViz; as ``aion export --format mcap``); ``format="dsg"`` the 4D scene graph as
        the spark_dsg file ``folder`` names (``dsg.json`` or ``.sparkdsg``, dynamics in each
        node's metadata; as ``aion export --format dsg``). Without ``format``, ``folder``'s
        suffix chooses as in ``aion export``: ``.mcap``, ``.json`` / ``.sparkdsg``, ``.ply`` /
        ``.pcd`` (the whole scene as one file) (a ``.png`` is :meth:`picture`'s), else a ply
        folder. Files of aion's no export wrote there are replaced only with ``force``.
        ``series=(start, end)``: every ``step`` (default ``"1h"``) from start to end, as
        ``aion export --from --to --step`` (a folder per time, or one MCAP file to scrub).
        The list returned is a :class:`~aion_cli.api_results.Files` whose ``notes`` are
        those ``aion export`` prints (a scene graph's: what a map does not store)."""
        from aion_cli.api_export import export_target, refuse_combination, written_notes
        from aion_cli.exports import write_export

        out = as_path(folder)
        format = export_target(format, out)
        self._check_file()
        force = check.flag(force, "force")
        times, zone = query_times(time, historical, series, step, tz, self.timezone)
        ends = self._path_ends(path)
        refuse_combination(format, out, ends, series)
        label = self._label
        written = write_export(
            self._loaded, label, out, times, zone, format, ends, series=series is not None,
            force=force,
        )
        files = Files(written.files)
        first = times[0]  # the forecast's notes first, as the command prints them
        forecast = [] if zone is None or first is None else self._notes(
            time if series is None else series[0], zone, first,
            None if series is None else [t for t in times if t is not None],
        )  # fmt: skip
        drawn = historical and ends is not None
        files.notes = (
            *forecast, *written_notes(self._loaded, written, out, drawn, ends is not None)
        )
        return files

    @one_at_a_time
    def picture(
        self,
        file: PathLike,
        *,
        time: TimeLike | None = None,
        historical: bool = False,
        tz: ZoneLike | None = None,
        path: PairOf[PlaceLike] | None = None,
        series: PairOf[TimeLike] | None = None,
        step: StepLike | None = None,
    ) -> Path:
        """The map from above at ``time`` (or as observed) as the PNG file ``file``, with the
        path planned between ``path = (start, goal)``; the file written (as ``aion export
        --format png``). ``series=(start, end)``: one panel every ``step`` (default ``"1h"``),
        as ``--from --to --step``."""
        from aion_cli.pictures.render import export_png

        self._check_file()
        times, zone = query_times(time, historical, series, step, tz, self.timezone)
        ends = self._path_ends(path)
        name = self.path.name if self.path is not None else MEMORY
        return export_png(self._loaded, name, as_path(file), times, zone, ends, option="file")

    @one_at_a_time
    def holdout(
        self, logs: Iterable[PathLike] | PathLike, *, radius: float = 1.0, **options: object
    ) -> HoldoutResult:
        """This map's forecast scored on held-out logs, read as ``aion build`` would read
        them into it (as ``aion evaluate holdout``): ``result.headings`` (heading NLL per
        model), ``result.activity`` (hourly Spearman, Poisson deviance, MAE), ``result.series``,
        ``result.notes``, ``result.to_dict()`` (its JSON). ``radius``: how near, in metres, a
        held-out detection must lie to an entry of the map to be scored on it (``--radius``;
        a positive number). ``options``: the build's reading
        options, as :func:`build` takes them (``detection_topics``, ``observed`` spans,
        ``map_frame``: default the frame the map records, else ``map``; ``base_frame``,
        ``graph_topic``, ``log_format``, ``detections_mapping``)."""
        from aion_cli.api_make import score_holdout

        self._check_file()
        return score_holdout(self._loaded, self.manifest, self.timezone, logs, radius, options)

    # -- saving ------------------------------------------------------------------------------

    @one_at_a_time
    def save(self, path: PathLike) -> Path:
        """Write the map to ``path`` (a new file, or an existing aion map, which is replaced
        atomically; anything else is refused). A map loaded from a file is copied byte for
        byte (its checksums stay valid); an in-memory map is written from its state."""
        from aion_cli.api_state import copy_map, write_state

        target = as_path(path)
        if self._file is not None:
            copy_map(self._file, target)
            return target
        write_state(self._loaded.state, self.timezone, target)
        self.path = target
        return target

    def __getstate__(self) -> dict[str, Any]:
        """A map loaded from a file pickles as that file, for another process (multiprocessing,
        Dask) to load again (:mod:`aion_cli.map_sharing`); an in-memory map pickles whole."""
        return pickled(self.__dict__, self._file)

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(unpickled(state))

    def __repr__(self) -> str:
        where = self._label
        with self._lock:  # from its manifest (what it cannot do too): its state is not read
            entries, kind = self._source.entry_count(), self._source.kind()
        if entries is None:
            return f"<aion.Map {where}: entries not read yet{kind}>"
        return f"<aion.Map {where}: {entries:,} entr{'y' if entries == 1 else 'ies'}{kind}>"
