"""The results of the Python API's queries: :class:`Table` (``Map.predict``, the records of
``aion predict``) and :class:`Plan` (``Map.plan``, the paths of ``aion plan``).

They are plain frozen values that need no map once made (``to_dict`` gives the document the
CLI prints as JSON), so they live apart from :mod:`aion_cli.api`'s :class:`~aion_cli.api.Map`,
which makes them; :mod:`aion_cli.api` re-exports both, and ``aion_cli.api.Table`` /
``aion_cli.api.Plan`` (and ``aion.Table`` / ``aion.Plan``) stay the names to use.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from aion_cli.errors import InputError

if TYPE_CHECKING:
    from pathlib import Path

    from aion_cli.engine.time_text import Zone
    from aion_cli.routes import Route, Routes

MEMORY = "<memory>"
"""What names a map made in memory (``Map.from_state``, not saved yet) where a file's path
would: ``Table.map`` and ``SeriesTable.map`` (their ``to_dict()``'s ``"map"``), the reprs of
the map and its results, an export's and a picture's label; in ``<...>``, as Python names
``<stdin>``, so no file name is read for it."""


@dataclass(frozen=True)
class Table:
    """Flows per entry at one time (or as observed): the records of ``aion predict``, a value
    that needs no map once made, to keep, compare or hand to another process.

    ``time_ns`` is the time asked for in UNIX nanoseconds (UTC), None for a historical table;
    ``time`` the same time as text in ``zone`` (the zone's name); ``bins`` the direction bins of
    a full turn (each ``360 / bins`` degrees). ``entries`` are the records, busiest first,
    with the fields of ``aion predict --format json``: ``x``, ``y``, ``z`` in metres in the
    map frame, ``flow`` in expected detections per window of the map (``window_s``, 600 s
    by default) and ``flow_per_hour`` per hour (detections, not people: a faster tracker
    counts more), ``direction_deg`` the busiest direction bin's, in degrees
    counter-clockwise from +x, ``mean_speed`` and ``speed_per_bin`` in m/s, ``histogram``
    each direction bin's probability (:mod:`aion_cli.predictions` lists every field).
    Equal tables compare equal (``==``); a table is not hashable (its records are dicts), as
    a :class:`Plan` and a series are not."""

    __hash__ = None  # type: ignore[assignment]  # not the fields' hash: an empty table's was

    map: str
    time_ns: int | None
    time: str | None
    zone: str | None
    bins: int
    entries: tuple[dict[str, Any], ...]
    hour_observed: bool | None = None
    """Whether any day of the map's data observed the time's hour of the day (None:
    historical, or a map that does not list its observed hours); where not, the forecast is
    extrapolated."""
    notes: tuple[str, ...] = ()
    """What the forecast at this time cannot say (:func:`aion_cli.forecast_notes.forecast_notes`:
    every entry at its static rate, a time long after the map's data, an hour no log
    observed), as ``aion predict`` prints them on stderr; not in :meth:`to_dict`; and, for
    rows none of which is a hash cell on a map whose places hold no detection, where the
    detections are (:func:`flowless_rows_note`, historical tables too)."""

    def records(self) -> list[dict[str, Any]]:
        """The entries as a list of fresh dicts (safe to change: their lists, ``histogram``
        and ``speed_per_bin``, are copies too)."""
        return [
            dict(e, histogram=list(e["histogram"]), speed_per_bin=list(e["speed_per_bin"]))
            for e in self.entries
        ]

    def to_dict(self) -> dict[str, Any]:
        """The document ``aion predict --format json`` prints."""
        from aion_cli.predictions import document

        doc = document(
            self.map, self.bins, self.records(), self.time_ns, None, self.hour_observed
        )
        doc.update(
            mode="historical" if self.time_ns is None else "predicted",
            time=self.time,
            zone=self.zone,
        )
        return doc

    def __len__(self) -> int:
        return len(self.entries)

    def __iter__(self) -> Iterator[dict[str, Any]]:
        return iter(self.records())

    def __repr__(self) -> str:
        """What the table is, in one line (not its records: a notebook shows a table of
        10^5 entries at once): its map, time, size and busiest entry."""
        when = "as observed" if self.time_ns is None else f"at {self.time}"
        n = len(self.entries)
        text = f"<aion.Table {self.map} {when}: {n:,} entr{'y' if n == 1 else 'ies'}"
        if n:
            first = self.entries[0]
            flow = first.get("flow")
            text += f", busiest {first['id']}" + (
                f" (flow {flow:.3g})" if isinstance(flow, float) else ""
            )
        return text + ">"


@dataclass(frozen=True)
class Plan:
    """A planned path (``aion plan``): node labels (``nodes``), ``length_m`` (metres),
    ``duration_s`` (seconds of walking at ``speed_mps``, m/s), ``cost`` and the arrival at
    each node (``arrival``: text in ``zone`` to the millisecond; ``arrival_ns``: UNIX
    nanoseconds); ``depart`` / ``depart_ns`` the departure alike. ``cost`` is the paper's
    ``d + (c_t + c_d) * d`` summed over the path's edges of ``d`` metres
    (:mod:`aion_cli.engine.planning`): metres weighted by
    how busy and how opposed each step is, so a path nobody walks costs its length and costs
    compare between paths of one map. ``distance_only`` is the shortest path beside it, with
    the temporal cost it would have had. Equal plans compare equal (``==``); a plan is not
    hashable (its nodes and records are lists and dicts), as a :class:`Table` is not."""

    __hash__ = None  # type: ignore[assignment]

    start: str
    goal: str
    depart: str
    depart_ns: int
    zone: str
    speed_mps: float
    nodes: list[str]
    length_m: float
    duration_s: float
    cost: float
    arrival: list[str]
    # the distance-only plan beside a temporal one (None: this is the distance-only plan)
    _distance_only: Plan | None = None
    snapped: list[dict[str, Any]] = field(default_factory=list)
    # with a departure span (``aion plan --leave``): every departure's cost, the best marked
    departures: list[dict[str, Any]] = field(default_factory=list)
    # the arrival times as UNIX nanoseconds (``arrival`` shows them to the millisecond)
    arrival_ns: list[int] = field(default_factory=list)
    # what the forecast at the departure (or the departures) cannot say, as aion plan notes it
    # (a tuple, as a Table's and a series' notes)
    notes: tuple[str, ...] = ()
    # whether any day of the map's data observed the departure's hour (where not, the costs
    # come from extrapolated flows); None for a map that does not list its observed hours
    hour_observed: bool | None = None

    @property
    def distance_only(self) -> Plan:
        """The shortest path, with the temporal cost it would have had (the distance-only
        plan's own is itself)."""
        return self if self._distance_only is None else self._distance_only

    def __repr__(self) -> str:
        """The plan in one line (not its nodes and arrival times, which may be thousands)."""
        text = (
            f"<aion.Plan {self.start} -> {self.goal} at {self.depart}: "
            f"{_path_summary(self)}"
        )
        if self._distance_only is not None:
            text += f"; distance only {_path_summary(self._distance_only)}"
        if self.departures:
            text += f"; the best of {len(self.departures)} departures"
        return text + ">"

    @classmethod
    def from_routes(
        cls,
        routes: Routes,
        zone: Zone,
        snapped: Sequence[dict[str, Any]] = (),
        hour_observed: bool | None = None,
    ) -> Plan:
        """The plan of :func:`aion_cli.routes.plan_routes`' two routes, times shown in
        ``zone`` (``aion plan`` prints its :meth:`to_dict`); ``hour_observed``: the
        departure's (``predictions.hour_flags``)."""
        from aion_cli.engine.node_ids import node_label
        from aion_cli.engine.time_text import format_ns

        depart = routes.depart_ns
        if depart is None:
            raise InputError("a plan departs at a time")

        def of(route: Route, other: Plan | None) -> Plan:
            return cls(
                node_label(routes.start),
                node_label(routes.goal),
                format_ns(depart, zone),
                depart,
                zone.name,
                routes.speed_mps,
                route.nodes,
                route.length_m,
                route.duration_s,
                route.cost,
                [format_ns(t, zone, millis=True) for t in route.arrival_ns],
                other,
                [dict(x) for x in snapped],
                arrival_ns=[int(t) for t in route.arrival_ns],
                hour_observed=hour_observed,
            )

        return of(routes.temporal, of(routes.distance_only, None))

    def to_dict(self) -> dict[str, Any]:
        """The document ``aion plan --format json`` prints (without ``map``)."""
        other = self.distance_only

        def part(p: Plan) -> dict[str, Any]:
            return {
                "path": list(p.nodes),
                "length_m": p.length_m,
                "duration_s": p.duration_s,
                "cost": p.cost,
                "arrival": list(p.arrival),
                "arrival_ns": list(p.arrival_ns),
            }

        return {
            "from": self.start,
            "to": self.goal,
            "depart": self.depart,
            "depart_ns": self.depart_ns,
            "zone": self.zone,
            "speed_mps": self.speed_mps,
            "temporal": part(self),
            "distance_only": part(other),
            "snapped": [dict(s, point=list(s["point"])) for s in self.snapped],
        } | (
            {} if self.hour_observed is None else {"hour_observed": self.hour_observed}
        ) | ({"departures": [dict(d) for d in self.departures]} if self.departures else {})


def _path_summary(plan: Plan) -> str:
    n = len(plan.nodes)
    return (
        f"{n:,} node{'' if n == 1 else 's'}, {plan.length_m:.1f} m, "
        f"{plan.duration_s:.0f} s, cost {plan.cost:.4g}"
    )


def departure_rows(
    plans: list[Any], best: int, zone: Zone, observed: Sequence[bool | None] = ()
) -> list[dict[str, Any]]:
    """One record per departure (JSON ``departures``): time, the temporal plan's cost, length
    and walking time, the distance-only path's cost then, and which is the best; with
    ``observed`` (``predictions.hour_flags`` of the departures), also whether any day
    observed the departure's hour (``hour_observed``; where not, its flows are
    extrapolated)."""
    from aion_cli.engine.time_text import format_ns

    rows = [
        {
            "depart": format_ns(p.depart_ns, zone),
            "depart_ns": p.depart_ns,
            "cost": p.temporal.cost,
            "length_m": p.temporal.length_m,
            "duration_s": p.temporal.duration_s,
            "distance_only_cost": p.distance_only.cost,
            "best": k == best,
        }
        for k, p in enumerate(plans)
    ]
    for row, seen in zip(rows, observed, strict=False):
        if seen is not None:
            row["hour_observed"] = seen
    return rows


def alike_note(rows: list[dict[str, Any]]) -> str | None:
    """The note for departures that all cost the same (within ``routes.DEPARTURE_TIE``, as
    the best is chosen): a static map's, whose "best" departure is only the earliest (at an
    hour the map observed, where others were not); None when their costs differ."""
    from aion_cli.routes import DEPARTURE_TIE

    costs = [float(row["cost"]) for row in rows]
    if len(costs) < 2 or max(costs) > min(costs) * (1.0 + DEPARTURE_TIE):
        return None
    which = "the earliest" if rows[0]["best"] else "the earliest at an hour the map observed"
    return (
        f"every departure costs the same ({min(costs):.1f}): the map forecasts no quieter time "
        f"to leave among them, so {which} is shown"
    )


DISTANCE_PLAN = "the temporal plan has no flow to avoid: it plans by distance alone"
"""What :func:`flowless_places_note` says of ``aion plan``'s temporal plan."""

DISTANCE_PATH = "the path drawn has no flow to avoid: it is the shortest by distance"
"""What it says of the path ``aion export --path-from/--path-to`` draws at a time."""


def flowless_places_note(state: Any, said: str = DISTANCE_PLAN) -> str | None:
    """The note for a plan over a scene graph none of whose places holds a detection (a fixed
    sensor built with the graph of another site or frame, a derived graph whose places were
    never stable: every detection on hash cells): the temporal plan has no flow to avoid, so
    it is the distance-only plan, which the table showed twice without saying why (``said``:
    of a path ``aion export`` draws, :data:`DISTANCE_PATH`). None when a place holds any."""
    from aion_cli.mapquery import detections_by_kind

    on_cells, on_nodes = detections_by_kind(state)
    if on_nodes > 0:
        return None
    places = 0 if state.graph is None else len(state.graph.places)
    where = (
        f"the map's {on_cells:,.0f} lie on hash cells, away from the places or before they "
        "were stable"
        if on_cells > 0
        else "the map holds none"
    )
    return f"none of the scene graph's {places:,} places holds a detection ({where}): {said}"


FLOWLESS_ROWS = (
    "its places, rooms and buildings show no flow: --layer cells lists the cells that hold them"
)
"""What :func:`flowless_rows_note` says of ``aion predict``'s rows."""


def flowless_rows_note(state: Any, kinds: Any) -> str | None:
    """:func:`flowless_places_note` for the rows of ``aion predict`` (and ``Map.predict``,
    its series, ``--historical``) whose ``kind`` are ``kinds`` (an array or list, one a row):
    when none of them is a hash cell (``--layer places``, ``rooms``, ``buildings``, or the
    places ``--node`` names) on a map whose places hold no detection, every row is a zero
    that does not say where the detections are. None when a row is a cell, there is no row,
    a place holds a detection, or the map holds none (an empty map's note says so)."""
    import numpy as np

    from aion_cli.mapquery import detections_by_kind

    kind = np.asarray(kinds, dtype=object)
    if kind.size == 0 or bool(np.any(kind == "cell")):
        return None
    on_cells, on_nodes = detections_by_kind(state)  # once, unless the note is said
    if on_nodes > 0 or on_cells == 0:
        return None
    return flowless_places_note(state, FLOWLESS_ROWS)


class Files(list["Path"]):
    """The files :meth:`aion_cli.api.Map.export` wrote (a list of ``Path``, as before), with
    the ``notes`` ``aion export`` prints beside them on stderr, in its order: what the
    forecast at the export's time (or its series' times) cannot say, as the ``notes`` of
    ``Map.predict`` (or ``Map.predict_series``) then; that a path drawn with
    ``historical=True`` is the shortest by distance; the frames of an earlier, longer series
    a series removed from its folder (:func:`aion_cli.export_stale.stale_note`: a folder of
    frames plays every frame it holds); for a scene graph (``format="dsg"``) what of the
    source graph a map does not store, and the detections the file leaves out when they are
    fewer than half (at least half is an :class:`~aion_cli.errors.AionWarning`). Notes, not
    warnings: the files hold what was asked. A list, not a frozen value: it compares equal
    to the list of the same paths."""

    notes: tuple[str, ...] = ()
