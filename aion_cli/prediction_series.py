"""Predicted flow of chosen entries over a series of times (``aion predict --from --to
--step``, :meth:`aion_cli.Map.predict_series`).

How busy is a corridor over the day, when is a room quiet? Each time of the series is the
prediction ``aion predict --time`` makes at that time, so every value equals that command's
``flow`` and ``flow_per_hour`` exactly: places and cells from the same predictor, evaluated
for the chosen rows only (:func:`entry_flows`); rooms and buildings as the sums of their
places' flows in the order the aggregated table (:func:`aion_cli.predictions.entry_table`)
adds them (:func:`_group_flows`). The entries are chosen as ``predict`` chooses
them (``--layer``, ``--node``, ``--at``), on the table of the first time (a map's rows are the
same at every time), ordered busiest first by their mean flow over the series (entries without
a known flow last, ties by id) and cut to ``top``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from aion_cli.engine.time_text import Zone
from aion_cli.time_steps import Step

if TYPE_CHECKING:
    from aion_cli.entry_columns import EntryColumns
    from aion_cli.mapquery import LoadedMap

F64 = npt.NDArray[np.float64]

#: the most times one series may have (as ``export --from --to``)
MOST_TIMES = 1000

#: values of a series reduced at a time while its entries are ordered (:func:`_means`)
BLOCK_VALUES = 1 << 22

#: CSV columns of a series: one row per (time, entry)
SERIES_CSV_KEYS = [
    "time", "time_ns", "id", "name", "kind", "layer", "x", "y", "z", "flow", "flow_per_hour",
    "hour_observed",
]


@dataclass(frozen=True, eq=False)
class SeriesTable:
    """The chosen entries (``entries``: id, name, kind, layer, x, y, z records, x, y, z in
    metres in the map frame; ``name`` the scene graph's room or building name, else None) and
    their predicted ``flow`` (expected detections per window of the map, ``window_s``) and
    ``flow_per_hour`` (per hour), float64[E, T] arrays, NaN where unknown, at ``times_ns``
    (UNIX nanoseconds, UTC); how many entries matched before ``top`` (``matched``). One
    array for the whole series, not a table per time: a day of 10^5 entries is a block a
    script slices (``flow[:, k]`` is the time ``k``, equal to ``Map.predict`` then)."""

    times_ns: list[int]
    entries: list[dict[str, Any]]
    flow: F64
    flow_per_hour: F64
    matched: int
    #: what the JSON document says beside the entries (:meth:`to_dict`); the API fills them
    map: str = ""
    zone: str | None = None
    times: tuple[str, ...] = ()
    hour_observed: tuple[bool | None, ...] | None = None
    #: what the forecasts cannot say (``forecast_notes.series_notes``; the API fills them, as
    #: ``aion predict --from`` prints them on stderr; not in the JSON)
    notes: tuple[str, ...] = ()
    #: ``entries`` as columns (``predict_series`` keeps them for the JSON and CSV writers of
    #: :mod:`aion_cli.entry_text`, which otherwise gather them from the dicts)
    columns: EntryColumns | None = None

    def to_dict(self, *, with_entries: bool = True) -> dict[str, Any]:
        """The JSON document of ``aion predict --from --to --format json``: the times (as
        text in the zone, and in ns), the zone, each entry with its series, and whether any
        day of the map's data observed each time's hour (when the map lists its hours).
        ``with_entries`` False: ``entries`` empty, for a writer that writes them itself."""
        doc: dict[str, Any] = {
            "map": self.map,
            "mode": "series",
            "times": list(self.times),
            "times_ns": list(self.times_ns),  # a copy: the document is the caller's to change
            "zone": self.zone,
            "entries": self.records() if with_entries else [],
        }
        if self.hour_observed is not None and None not in self.hour_observed:
            doc["hour_observed"] = list(self.hour_observed)
        return doc

    def __eq__(self, other: object) -> bool:
        """The same times, entries and values (NaN equal to NaN): the generated comparison
        asked the arrays' truth value and raised ``ValueError``."""
        if not isinstance(other, SeriesTable):
            return NotImplemented
        return (
            (self.times_ns, self.entries, self.matched, self.map, self.zone, self.times)
            == (other.times_ns, other.entries, other.matched, other.map, other.zone, other.times)
            and self.hour_observed == other.hour_observed
            and np.array_equal(self.flow, other.flow, equal_nan=True)
            and np.array_equal(self.flow_per_hour, other.flow_per_hour, equal_nan=True)
        )

    def __len__(self) -> int:
        """The entries, as ``len`` of an :class:`aion.Table` counts them."""
        return len(self.entries)

    def __iter__(self) -> Iterator[dict[str, Any]]:
        """:meth:`records`, as iterating an :class:`aion.Table` yields its records."""
        return iter(self.records())

    def __repr__(self) -> str:
        """What the series is, in one line (not its entries and arrays, which a notebook
        would print whole): its map, size and span."""
        from aion_cli.api_results import MEMORY

        n, k = len(self.entries), len(self.times_ns)
        text = (
            f"<aion.SeriesTable {self.map or MEMORY}: {n:,} entr{'y' if n == 1 else 'ies'}"
            f" x {k:,} time{'' if k == 1 else 's'}"
        )
        if self.times:
            text += f", {self.times[0]}" + (f" .. {self.times[-1]}" if k > 1 else "")
        return text + ">"

    def records(self) -> list[dict[str, Any]]:
        """One record per entry with its series as lists (None where unknown): the
        ``entries`` of ``aion predict --from --to --format json``."""
        return [
            entry | {"flow": _listed(self.flow[k]), "flow_per_hour": _listed(self.flow_per_hour[k])}
            for k, entry in enumerate(self.entries)
        ]

    def long_rows(self, labels: Sequence[str]) -> list[dict[str, Any]]:
        """One row per (time, entry), times outermost: ``--format csv`` (``labels``: each
        time as text; ``hour_observed`` as JSON writes it, ``true`` / ``false``, None where
        not known)."""
        seen = self.observed_text()
        return [
            {"time": labels[j], "time_ns": t}
            | entry
            | {
                "flow": _value(self.flow[k, j]),
                "flow_per_hour": _value(self.flow_per_hour[k, j]),
                "hour_observed": seen[j],
            }
            for j, t in enumerate(self.times_ns)
            for k, entry in enumerate(self.entries)
        ]


    def observed_text(self) -> list[str | None]:
        """Per time, ``hour_observed`` as CSV text (``true`` / ``false``, as in the JSON);
        None for every time where the map does not list the hours it observed."""
        from aion_cli.predictions import observed_text

        flags = self.hour_observed
        if flags is None or None in flags:
            return [None] * len(self.times_ns)
        return [observed_text(seen) for seen in flags]


def _value(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _listed(row: F64) -> list[float | None]:
    return [_value(x) for x in row.tolist()]


def series_times(
    start_ns: int,
    end_ns: int,
    step: Step,
    zone: Zone,
    names: tuple[str, str] = ("--from", "--to"),
    noun: str = "times",
    typed: object = None,
) -> list[int]:
    """``start, start + step, ...`` up to ``end`` inclusive (an end that falls on a step is
    one of the times), each time :func:`aion_cli.time_steps.step_time`'s: a step in days or
    weeks keeps the wall-clock time of ``start`` in ``zone`` across a daylight-saving change,
    hours, minutes and seconds are elapsed time. The one place the series of ``predict``,
    ``export``, ``plan --leave`` and the API's are made. :class:`InputError` for an end before
    the start or more than :data:`MOST_TIMES` times. ``names``: what the caller calls the
    start and the end (the CLI's options, or the API's arguments); ``noun``: what the times
    are (``departures`` of a plan, ``frames`` of an export); ``typed``: the start as the user
    gave it, whose wall-clock time a step in days keeps on the other days where a clock
    change skipped it (:func:`aion_cli.wall_clock.skipped_wall`: 02:30 again, not 03:30)."""
    from aion_cli.engine.time_text import format_ns
    from aion_cli.errors import InputError
    from aion_cli.time_steps import step_time
    from aion_cli.timeparse import offset_changes_near
    from aion_cli.wall_clock import skipped_wall

    wall = skipped_wall(typed, zone, start_ns) if step.days else None

    if step.days < 0 or step.exact_ns < 0 or step.nominal_ns <= 0:
        raise InputError(f"the step must be positive, got {step}")
    if end_ns < start_ns:
        first, last = names
        # a wall-clock time a clock change skips is read an hour later: 02:30..03:10 on
        # Berlin's spring change is 03:30..03:10, which the times read must show
        change = any(offset_changes_near(t, zone, 1) for t in (start_ns, end_ns))
        raise InputError(
            f"{last} is before {first} (read as {format_ns(start_ns, zone)} .. "
            f"{format_ns(end_ns, zone)}"
            + (": a clock change skips or repeats an hour there)" if change else ")"),
            hint=f'give a later {last}, e.g. {first} "2026-01-12 06:00" {last} "2026-01-12 20:00"'
            if first.startswith("--")
            else f"give a later {last}",
        )
    # the last step at or before the end: exact for elapsed steps; for calendar days the
    # estimate of 24 h a day is off by the zone's changes of offset, which the loops correct
    steps = (end_ns - start_ns) // step.nominal_ns
    if step.days:
        while steps > 0 and step_time(start_ns, step, steps, zone, wall) > end_ns:
            steps -= 1
        while step_time(start_ns, step, steps + 1, zone, wall) <= end_ns:
            steps += 1
    count = steps + 1
    if count > MOST_TIMES:
        cli = names[0].startswith("--")
        raise InputError(
            f"the series would have {count:,} {noun} (at most {MOST_TIMES:,})",
            hint=f"use a larger {'--step' if cli else 'step'} or a shorter span",
        )
    # a zone that skips a whole calendar day (Pacific/Apia, 2011-12-30) maps that day's
    # wall-clock time to the next day's instant: the time is taken once
    return list(dict.fromkeys(step_time(start_ns, step, k, zone, wall) for k in range(count)))


def predict_series(
    loaded: LoadedMap,
    times_ns: Sequence[int],
    layer: str = "all",
    nodes: Sequence[str | int] = (),
    at: str | None = None,
    top: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> SeriesTable:
    """The series of the entries asked for (see the module doc); ``progress(k)`` after each
    time."""
    from aion_cli.entry_columns import entry_columns
    from aion_cli.entry_selection import chosen_entries
    from aion_cli.predictions import entry_ids

    times = [int(t) for t in times_ns]
    if not times:
        raise ValueError("a series needs at least one time")
    first, layer, index, names = chosen_entries(loaded, times[0], layer, nodes, at)
    if layer in ("rooms", "buildings"):  # sums over places, as the aggregated table's
        flow = _group_flows(loaded, first.node_id[index], times, layer, progress)
    else:
        flow = entry_flows(loaded, index, times, progress)
    known, mean = _means(flow)
    ids = np.asarray([str(i) for i in entry_ids(first, index)], dtype=str)
    order = np.lexsort((ids, np.where(known, -mean, np.inf))) if index.size else index
    order = order[:top] if top is not None else order
    kept = flow[order]  # the rows of the kept entries, in their order
    per_hour = kept * (3600.0 / first.window_s)  # as the table's descriptors compute it
    columns = entry_columns(first, index[order], names)
    entries = columns.records(("id", "name", "kind", "layer", "x", "y", "z"))
    return SeriesTable(times, entries, kept, per_hour, int(index.size), columns=columns)


def _means(flow: F64) -> tuple[npt.NDArray[np.bool_], F64]:
    """Which rows of ``flow`` have a known value, and each such row's mean over its known
    values (0 for the others), :data:`BLOCK_VALUES` values at a time: a row's mean is
    reduced over that row alone, so it is the number ``np.nanmean`` of the whole array
    gives, without the whole array's temporaries (a mask, a copy of the known rows and one
    with NaN as 0: three more copies of 0.9 GB for 10^5 entries over 1,000 times)."""
    rows = max(1, BLOCK_VALUES // max(1, flow.shape[1]))
    known = np.zeros(flow.shape[0], dtype=bool)
    mean = np.zeros(flow.shape[0])
    for a in range(0, flow.shape[0], rows):
        block = flow[a : a + rows]
        some = np.asarray(np.isfinite(block).any(axis=1), dtype=bool)
        known[a : a + rows] = some
        if some.any():
            mean[a : a + rows][some] = np.nanmean(block[some], axis=1)
    return known, mean


def _group_flows(
    loaded: LoadedMap,
    group_ids: npt.NDArray[np.uint64],
    times: list[int],
    layer: str,
    progress: Callable[[int], None] | None,
) -> F64:
    """The flow of the rooms or buildings ``group_ids`` at ``times``, float64[G, T]: every
    entry's flow by the predictor's batch path, summed per group in entry order
    (:func:`aion_cli.predictions.group_flow_series`), the sums the aggregated table makes
    at each time, without a whole table per time."""
    from aion_cli.predictions import group_flow_series

    level: Literal["rooms", "buildings"] = "rooms" if layer == "rooms" else "buildings"
    _, ids, flows = group_flow_series(loaded, times, level, progress)
    column = np.minimum(np.searchsorted(ids, group_ids), max(len(ids) - 1, 0))
    if len(group_ids) and (len(ids) == 0 or (ids[column] != group_ids).any()):
        raise ValueError("a room of the aggregated table has no series (a bug)")
    out: F64 = flows[:, column].T
    return out


def entry_flows(
    loaded: LoadedMap,
    index: npt.NDArray[np.int64],
    times: list[int],
    progress: Callable[[int], None] | None,
) -> F64:
    """The flow of table rows ``index`` at ``times``, float64[E, T], evaluated for those
    rows only (``Predictor.pairs``, a block of times at a time) instead of a whole table per
    time: the table's rows are the predictor's rows, then the graph's places without an
    entry, whose flow is 0. Element by element the same arithmetic as the table's."""
    from aion_cli.predictions import SERIES_PAIRS

    rows, predictor = loaded.state.predictor()
    out = np.zeros((index.size, len(times)))
    own = np.flatnonzero(index < rows.size)
    members = index[own]
    per_step = max(1, SERIES_PAIRS // max(1, members.size))
    for a in range(0, len(times), per_step):
        block = np.asarray(times[a : a + per_step], dtype=np.int64)
        if members.size:
            flow = predictor.flows(np.tile(members, block.size), np.repeat(block, members.size))
            out[own, a : a + block.size] = flow.reshape(block.size, members.size).T
        if progress is not None:
            progress(a + block.size)
    return out


def described(
    table: SeriesTable,
    map_path: Any,
    zone: Zone,
    labels: Sequence[str],
    hour_observed: Sequence[bool | None] | None,
) -> SeriesTable:
    """``table`` with what its JSON document says beside the entries (:meth:`to_dict`)."""
    from dataclasses import replace

    flags = None if hour_observed is None else tuple(hour_observed)
    return replace(
        table, map=str(map_path), zone=zone.name, times=tuple(labels), hour_observed=flags
    )
