"""``Map.plan`` (:class:`aion_cli.api.Map` binds it as its method): a path between two
places at a time, beside the distance-only path, or the best departure between two times
(``leave``), as ``aion plan``.

Split from :mod:`aion_cli.api`: a function of the map (``self``), bound as the method
``Map.plan`` and named so, whose arguments, docstring and keyword checks it keeps."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from aion_cli import api_checks as check
from aion_cli.api_checks import PairOf, PlaceLike, StepLike, TimeLike, ZoneLike
from aion_cli.api_results import Plan
from aion_cli.errors import InputError
from aion_cli.map_sharing import one_at_a_time

if TYPE_CHECKING:
    from aion_cli.api import Map


@one_at_a_time
def plan(
    self: Map[Any],
    start: PlaceLike,
    goal: PlaceLike,
    *,
    time: TimeLike | None = None,
    tz: ZoneLike | None = None,
    speed: float | None = None,
    leave: PairOf[TimeLike] | None = None,
    step: StepLike | None = None,
) -> Plan:
    """A path from ``start`` to ``goal`` (node ids ``"p12"``, rooms or buildings by id or
    name, ``"R3"``, ``"kitchen"``, or coordinates ``"x,y"`` in metres in the map frame,
    which snap to the nearest place: ``Plan.snapped``) departing at ``time`` (default now),
    avoiding busy and opposing flows, with the distance-only path beside it
    (``Plan.distance_only``), as ``aion plan``. ``speed``: the walking speed in m/s (0.01 ..
    20; None: the map's ``plan_speed``), which times the arrival at each place, where its
    forecast is read. With ``leave=(earliest, latest)``: the best departure every ``step`` (as
    :meth:`predict_series` takes it: ``"10m"``, ``"1d"``, seconds, a ``timedelta`` or a
    ``numpy.timedelta64``; ``"10m"`` when not given) from ``earliest`` up to ``latest``,
    which must not be earlier (``(T, T)`` is the one departure T), every departure's cost
    in ``Plan.departures`` (``--leave``); ``step`` without ``leave`` is refused, as
    ``--step`` without ``--leave``."""
    from dataclasses import replace

    from aion_cli.api_results import flowless_places_note
    from aion_cli.mapquery import entry_positions, nav_graph
    from aion_cli.predictions import hour_flags
    from aion_cli.routes import plan_departures, plan_routes, resolve_ends

    start, goal = check.endpoint(start, "start"), check.endpoint(goal, "goal")
    if speed is not None and not 0.01 <= check.real(speed, "speed") <= 20.0:
        raise InputError(
            f"speed must be 0.01 .. 20 m/s, got {speed}", hint="a walking speed, e.g. 1.0"
        )
    if leave is not None and time is not None:
        raise InputError(
            "choose time or leave=(earliest, latest), not both",
            hint="time= plans one departure; leave= finds the best between two times",
        )
    if step is not None and leave is None:
        raise InputError("step needs leave", hint='e.g. leave=("08:00", "10:00"), step="10m"')
    self._check_file()
    t_ns, zone = self._time("now" if time is None else time, tz)
    nav = nav_graph(self._loaded)
    graph = self._loaded.graph
    a, b = resolve_ends(start, goal, nav, graph, entry_positions(self._loaded.state))
    snapped = [s for s in (a.snapped("--from"), b.snapped("--to")) if s is not None]
    # places without people: the temporal plan is by distance, as aion plan says
    flowless = tuple(n for n in (flowless_places_note(self._loaded.state),) if n is not None)
    if leave is None:
        routes = plan_routes(self._loaded, a.node_id, b.node_id, t_ns, speed, nav)
        made = Plan.from_routes(routes, zone, snapped, hour_flags(self._loaded, [t_ns])[0])
        notes = (*self._notes(time, zone, t_ns, None, "departures"), *flowless)
        return replace(made, notes=notes)

    from aion_cli.api_results import alike_note, departure_rows
    from aion_cli.api_words import api_text
    from aion_cli.prediction_series import series_times
    from aion_cli.time_steps import parse_step
    from aion_cli.wall_clock import wall_clock_note

    every = parse_step(check.step("10m" if step is None else step), "step")
    first, last = check.pair(leave, "leave", "earliest, latest")
    earliest = self._time(first, tz)[0]
    latest = self._time(last, tz, after_ns=earliest)[0]
    if latest < earliest:  # as --leave START..END; (T, T) is the one departure T
        raise InputError(
            "leave: the latest departure is before the earliest",
            hint="give leave=(earliest, latest) with latest later (or the same, for one)",
        )
    times = series_times(
        earliest, latest, every, zone, ("leave[0]", "leave[1]"), "departures", first
    )
    observed = hour_flags(self._loaded, times)
    plans, best = plan_departures(
        self._loaded, a.node_id, b.node_id, times, speed, nav, observed=observed
    )
    made = Plan.from_routes(plans[best], zone, snapped, observed[best])
    rows = departure_rows(plans, best, zone, observed)
    alike = [n for n in (alike_note(rows),) if n is not None]  # as plan --leave says
    # the earliest departure, typed as a wall-clock time a clock change skips or repeats: the
    # instant taken, as plan --leave (and predict_series' start) say it
    changed = wall_clock_note(first, zone, times[0])
    typed = () if changed is None else (api_text(changed),)
    notes = (
        *typed, *self._notes(None, zone, times[best], times, "departures"), *flowless, *alike
    )
    return replace(made, departures=rows, notes=notes)


plan.__qualname__ = "Map.plan"  # the method Map binds it as: its refusals name Map.plan
