"""What a forecast at a time can and cannot say, from the map's manifest: the notes ``predict``,
``plan``, ``export`` and ``report`` print beside the time they used.

Situations that surprise people and look like defects when unexplained:

* **Every entry forecasts its static rate**, so the tables at 03:30 and at 12:30 are the same.
  An entry chooses a time-varying family by its day-ahead scores, and needs two scored days
  for that (each day scored against the days before it): a map of one or two days (or of a
  few hours) has none, and forecasts the same at every hour unless its total is reconciled to
  a map-wide rhythm.
* **The time lies far outside the map's data**: more than a week before its first detection
  or after its last (a week, one turn of the longest rhythm learnt, either side). The
  forecast is the rhythm the map learnt (its day and week), repeated; it knows nothing of
  what changed since (or before).
* **The time falls on a kind of day the map never saw**: a Saturday, from a map of weekdays
  only. The profiles keep weekdays and weekends apart (``profile = "day_weekend"``, the
  default, or every day of the week with ``"week"``), so a kind of day without data has no
  hours of its own: its forecast follows the hours and level of the kinds seen, the map's,
  each group's and each place's own (:func:`~aion_cli.engine.temporal.shape_prior.by_hour`),
  which a quieter weekend would not show.
* **No log observed the time's hour on any day** (a tracker that recorded 09:00-18:00 only,
  asked about 03:00): the manifest lists the profile bins observed (``families.observed_bins``)
  and the forecast there is extrapolated from the hours observed, not measured: each entry's
  static rate, its detections over all its observed windows — a mean, so where one hour of the
  day held most detections (a crowd at 17:00) it lies above the quieter hours' own rates. A series
  names every such hour (:func:`series_notes`); ``predict``'s JSON flags each time
  (:func:`~aion_cli.bins_observed.hour_observed`), the report's charts mark each hour
  (:func:`~aion_cli.bins_observed.bin_observed`, per kind of day and hour: a Saturday from a
  map of weekdays is marked too), and ``aion info`` lists the hours observed
  (:func:`~aion_cli.bins_observed.observed_hours`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from aion_cli import note_words as words
from aion_cli.bins_observed import calendar_of, hour_observed, hours_of, observed_bins
from aion_cli.bins_observed import observed_hours as observed_hours
from aion_cli.engine.temporal.calendar import DAY_NS
from aion_cli.sensor_notes import recording_windows, sensor_share, silent_sensor

if TYPE_CHECKING:
    from aion_cli.engine.time_text import Zone
    from aion_cli.manifest import Manifest

STATIC_THERE = (
    "every entry at its static rate, its mean per window over all the hours observed "
    "(one busy hour raises it above the quiet ones)"
)
"""What the forecast at an hour no log observed is (``Predictor``'s extrapolated bins): an
entry's detections over its observed windows, the same at every such hour, and above the quieter
hours' own rates where one hour of the day held most of the detections."""

FAR_AFTER_NS = 7 * DAY_NS
"""Beyond this after a map's last data a forecast repeats a rhythm learnt long before; a
week is one turn of the longest rhythm the default model learns."""

FAR_BEFORE_NS = FAR_AFTER_NS
"""Beyond this before a map's first data a forecast repeats a rhythm learnt long after: the
same week, for the same reason (a time 52 seconds before the first detection, the night
before it, had been said to lie before the map's data, as one months before)."""


PLAN_COSTS = "; the plan's costs come from these extrapolated flows"
"""The end of that note for a plan departing at such an hour (its costs are those flows')."""


def forecast_notes(
    manifest: Manifest,
    t_ns: int,
    noun: str = "times",
    shown: Zone | None = None,
    series: list[int] | None = None,
) -> list[str]:
    """The notes for a forecast at ``t_ns`` (UNIX ns) from the map of ``manifest``; empty
    when there is nothing to say. ``noun`` "departures": a plan's, whose costs are said to
    come from the flows of an hour no log observed. ``shown``: the zone the time is printed
    in (``--tz``; default UTC), which :func:`unseen_day` names its day against; ``series``:
    the times ``t_ns`` belongs to, whose days of its kind :func:`unseen_day` names too."""
    empty = empty_map(manifest)
    if empty is not None:  # nothing else to say of a map of no entry
        return [empty]
    notes = []
    static = all_static(manifest)
    if static is not None:
        notes.append(static)
    where = _outside(
        manifest.start_ns, manifest.end_ns, int(t_ns), static is not None, manifest.timezone
    )
    if where is not None:
        notes.append(where)
    unseen = None if static is not None else unseen_day(manifest, int(t_ns), shown, series)
    if unseen is not None:
        notes.append(unseen)
    from aion_cli.fixed_sensor import silent_advice

    # once: an all-static note that found no rhythm carries the advice; one of too few days
    # or of the static family only does not, and the sensor's own note must say it
    advice = silent_advice(manifest.counts)
    silent = None if static is not None and advice in static else silent_sensor(manifest)
    if silent is not None:
        notes.append(silent)
    unobserved = _unobserved_hour(manifest, int(t_ns))
    if unobserved is not None:
        notes.append(unobserved + (PLAN_COSTS if noun == "departures" else ""))
    return notes


EMPTY_MAP = (
    "the map holds no entries (no place, no hash cell: it has observed no detection, and no "
    "scene graph gave it places), so it lists nothing"
)
"""The note of a query of a map of no entry (``Map.from_state`` of a state fed nothing): its
table and exported files are empty, not a time when nobody walks."""


def empty_map(manifest: Manifest) -> str | None:
    """:data:`EMPTY_MAP` for a map whose counts say it holds no place and no hash cell, else
    None (a map of a scene graph's places lists them, with no flow)."""
    counts = manifest.counts
    return EMPTY_MAP if counts.get("nodes") == 0 and counts.get("cells") == 0 else None


def query_notes(
    manifest: Manifest,
    time: object,
    zone: Zone,
    t_ns: int,
    series: list[int] | None = None,
    noun: str = "times",
) -> list[str]:
    """What the commands note beside the time a query used (``cli.common.announce_time``),
    for the API's results: which instant ``time``, a wall-clock time a clock change skips or
    repeats, was read as (text, or a naive ``datetime``: ``wall_clock_note``), then the notes
    of a forecast at ``t_ns`` (of the ``series`` of times it belongs to, ``noun`` naming them)."""
    from aion_cli.wall_clock import wall_clock_note

    changed = wall_clock_note(time, zone, t_ns)  # a string, a naive datetime (API)
    notes = [] if changed is None else [changed]
    if series:
        return notes + series_notes(manifest, series, t_ns, noun, zone)
    return notes + forecast_notes(manifest, t_ns, noun, zone)


def all_static(manifest: Manifest) -> str | None:
    """Why every entry of the map forecasts its static rate at every time (None: some do
    not): too few scored days, or no rhythm that beat the rate on them."""
    families = manifest.families
    flow = families.get("flow") or {}
    entries = sum(int(n) for n in flow.values())
    if entries == 0 or int(flow.get("static", 0)) != entries or families.get("reconciled"):
        return None
    days = int(families.get("scored_days", 0))
    text = "every entry forecasts its static rate, whatever the time: "
    only = _static_only(manifest.config)
    if only is not None:
        return text + only
    if days < 2:
        return text + (
            f"the map has {days} scored day{'' if days == 1 else 's'}, and an entry needs two "
            "(each scored against the days before it) to follow a daily or weekly rhythm; "
            "build from more days of logs"
        )
    text += (
        f"on the map's {days} scored days no daily or weekly rhythm forecast the next day "
        "better than that rate"
    )
    from aion_cli.fixed_sensor import share_text, silent_advice

    share = sensor_share(manifest)
    if share is not None and share < 0.5:
        whose = "its logs'" if recording_windows(manifest) else "the"
        text += (
            f" (its fixed sensor observed {share_text(share)} of {whose} time: only the windows in "
            f"which a log recorded a message; {silent_advice(manifest.counts)})"
        )
    return text


def _static_only(config: Mapping[str, Any]) -> str | None:
    """Why a map whose model has the static family only (``families = ["static"]``: every
    temporal family switched off) forecasts its static rates, and what its histograms are;
    None for a model with a temporal family (or a config that does not say)."""
    families = config.get("families")
    if not isinstance(families, list) or families != ["static"]:
        return None
    text = (
        'the map\'s model has the static family only (families = ["static"]), so its flows '
        "are those of --historical"
    )
    prior = config.get("direction_prior")
    if type(prior) in (int, float) and prior == 0:
        return (
            text + " and so are its directions: the forecast is the historical map "
            "(--historical) at every time"
        )
    shown = (
        f" (direction_prior = {prior:g})" if type(prior) in (int, float)
        else ' (direction_prior = "auto": its strength estimated from the map)'
        if prior == "auto" else ""
    )
    return text + (
        "; its direction histograms are pooled toward their neighbourhood's"
        f"{shown}, where --historical gives the raw proportions (direction_prior = 0 "
        "makes them equal)"
    )


def _outside(
    start_ns: int | None, end_ns: int | None, t_ns: int, static: bool, zone: str | None = None
) -> str | None:
    """A note when ``t_ns`` lies over a week before or after the map's data; the data's
    days are given in the map's zone (``zone``, UTC when None), as ``info`` shows them."""
    far = far_from_data(start_ns, end_ns, t_ns, zone)
    if far is None:
        return None
    text = f"this time is {far}"
    before = start_ns is not None and t_ns < int(start_ns)
    if static:
        return text
    text += ": the forecast repeats the rhythm the map learnt"
    return text if before else text + " and knows nothing of what changed since"


def data_days(start_ns: int, end_ns: int, zone: str | None = None) -> str:
    """The days of a map's data in ``zone`` (UTC when None): ``2026-01-05 to 2026-01-09``,
    one date for a day's (the span ends before ``end_ns``)."""
    start, end = int(start_ns), int(end_ns)
    first, last = words.day(start, zone), words.day(max(start, end - 1), zone)
    return first if first == last else f"{first} to {last}"


def far_from_data(
    start_ns: int | None, end_ns: int | None, t_ns: int, zone: str | None = None
) -> str | None:
    """``"47 weeks after the map's data (2026-01-05 to 2026-01-09)"`` when ``t_ns`` lies
    over a week before or after the map's data (:data:`FAR_BEFORE_NS`, :data:`FAR_AFTER_NS`),
    its days in the map's zone ``zone``; None otherwise, and for a map without data."""
    if start_ns is None or end_ns is None:
        return None
    start, end = int(start_ns), int(end_ns)
    if start - FAR_BEFORE_NS <= t_ns <= end + FAR_AFTER_NS:
        return None
    before = t_ns < start
    return (
        f"{words.duration(start - t_ns if before else t_ns - end)} "
        f"{'before' if before else 'after'} the map's data ({data_days(start, end, zone)})"
    )


def unseen_day(
    manifest: Manifest, t_ns: int, shown: Zone | None = None, series: list[int] | None = None
) -> str | None:
    """The note for a time on a kind of day (weekend or weekday; with the weekly profile, a
    day of the week) that no day of the map's data span is, or that the span holds but no
    log observed (``observed_bins``: a fixed sensor whose tracker is silent when nobody is
    there records no window of a weekend nobody came on), in the map's zone; None when the
    map observed that kind of day (or, for a map that does not list its observed bins, its
    span holds one) or the profile does not tell days apart. The day is named with the
    map's zone where the time, printed in ``shown`` (default UTC), falls on another day of
    the week there. ``series``: the times ``t_ns`` belongs to; the note names each day of
    the week among them of the time's kind (a Saturday or Sunday), in the order reached."""
    import numpy as np

    from aion_cli.engine.temporal.calendar import weekday_of

    start, end = manifest.start_ns, manifest.end_ns
    calendar = calendar_of(manifest.config, manifest.timezone)
    if start is None or end is None or calendar is None:
        return None
    profile = calendar.profile
    if profile not in ("day_weekend", "week"):
        return None
    first, last, day = (int(d) for d in calendar.day([int(start), max(int(start), int(end) - 1),
                                                      t_ns]))
    span_days = weekday_of(np.arange(first, min(last, first + 6) + 1))
    weekday = int(weekday_of(day))
    kind = weekday if profile == "week" else int(weekday >= 5)
    kinds = span_days if profile == "week" else (span_days >= 5).astype(np.int64)
    in_span = bool((kinds == kind).any())
    bins = observed_bins(manifest.families)
    observed = {b // calendar.bins_per_day for b in bins} if bins else None
    if in_span and (observed is None or kind in observed):
        return None
    # a day as the map's clock has it: say which clock where the time as printed is another
    # day (Friday 20:00 UTC is a Saturday in Tokyo; Sunday 00:30 in London, with --tz
    # Europe/London, a Saturday on a UTC map's clock)
    named = [weekday]
    if series and profile == "day_weekend":  # the series' days of this kind, as reached
        reached = dict.fromkeys(int(d) for d in weekday_of(calendar.day(list(series))))
        named = [d for d in reached if int(d >= 5) == kind]
        named = named if weekday in named else [weekday, *named]
    day_name = " or ".join(words.WEEKDAYS[d] for d in named) + (
        f" ({calendar.timezone} time)" if _weekday_in(t_ns, shown) != weekday else ""
    )
    if profile == "week":
        what = f"no {words.WEEKDAYS[weekday]}"
        follows = (
            f"its hour-of-week profiles have no {day_name} of their own, so the "
            "forecast follows the hours of the days it saw"
        )
    else:
        what = "no weekend day" if kind else "no weekday"
        seen_kind = "weekdays" if kind else "weekends"
        follows = (
            f"its hour-of-day profiles know {seen_kind} only, so a forecast for a "
            f"{day_name} follows the {seen_kind}' rhythm and level"
        )
    if not in_span:
        return f"the map's data ({words.span_days(first, last)}) holds {what}: {follows}"
    every = weekday_of(np.arange(first, last + 1))
    held = int(((every if profile == "week" else every >= 5) == kind).sum())
    text = (
        f"the map observed {what} (its data, {words.span_days(first, last)}, holds {held}, but no "
        f"log recorded a window of them): {follows}"
    )
    from aion_cli.fixed_sensor import SILENT_HINT, silent_advice

    share = sensor_share(manifest)
    # below, silent_sensor's note gives the hint; a tracker that publishes messages with
    # nobody in them is not silent: its unrecorded days were not observed
    if share is not None and share >= 0.5 and silent_advice(manifest.counts) == SILENT_HINT:
        text += f"; {SILENT_HINT}"
    return text


def series_notes(
    manifest: Manifest,
    times_ns: list[int],
    at: int | None = None,
    noun: str = "times",
    shown: Zone | None = None,
) -> list[str]:
    """The notes for a series of forecasts: those of the time ``at`` (default: the first),
    with the hours no log observed named for the whole series rather than for one time
    (``noun``: what the times are, e.g. "departures"), and a kind of day the map never saw
    named where the series reaches one after that time (Friday to Monday from a map of
    weekdays: its Saturday's note), and its first or last time where that lies over a week
    before or after the map's data and the time ``at`` does not. ``shown``: the zone the
    times are printed in (:func:`unseen_day`)."""
    when = times_ns[0] if at is None else int(at)
    notes = [
        n for n in forecast_notes(manifest, when, shown=shown, series=times_ns)
        if not n.startswith(_NO_LOG)
    ]
    far = _far_end(manifest, times_ns, when, noun)
    if far is not None:
        notes.append(far)
    calendar = calendar_of(manifest.config, manifest.timezone)
    if calendar is not None and all_static(manifest) is None and unseen_day(manifest, when) is None:
        unseen = _first_unseen_day(manifest, calendar, times_ns, shown)
        if unseen is not None:
            notes.append(unseen)
    unobserved = unobserved_hours(manifest, times_ns, noun)
    return notes if unobserved is None else [*notes, unobserved]


def unobserved_hours(manifest: Manifest, times_ns: list[int], noun: str = "times") -> str | None:
    """The note on those of ``times_ns`` whose hour of the day no log of the map observed on
    any day (their forecast is extrapolated); None when every one's was observed, or the map
    does not list its observed bins."""
    calendar = calendar_of(manifest.config, manifest.timezone)
    observed = hour_observed(manifest, times_ns)
    if observed is None or all(observed) or calendar is None:
        return None
    per_day = calendar.bins_per_day
    missed = sorted({int(b) % per_day for b, seen in
                     zip(calendar.profile_bin(times_ns), observed, strict=True) if not seen})
    n = len(observed) - sum(observed)
    return (
        f"{n} of the {len(observed)} {noun} fall in hours no log observed on any day "
        f"({words.clock_ranges(missed, calendar.bin_s)} {calendar.timezone}; the map observed "
        f"{words.clock_ranges(hours_of(manifest, per_day), calendar.bin_s)}): their forecast is "
        f"extrapolated from the hours observed, not measured: {STATIC_THERE}"
    )


def _far_end(manifest: Manifest, times_ns: list[int], when: int, noun: str) -> str | None:
    """:func:`_outside`'s note for the first or the last of ``times_ns`` (a series from the
    map's week to months after it), None where ``when`` has its own or neither end has one."""
    static = all_static(manifest) is not None
    start, end, zone = manifest.start_ns, manifest.end_ns, manifest.timezone
    if not times_ns or _outside(start, end, when, static, zone) is not None:
        return None
    for which, t in (("first", min(times_ns)), ("last", max(times_ns))):
        note = _outside(start, end, int(t), static, zone)
        if note is not None:
            return note.replace("this time is", f"the {which} of the {noun} is", 1)
    return None


def _first_unseen_day(
    manifest: Manifest, calendar: Any, times_ns: list[int], shown: Zone | None = None
) -> str | None:
    """:func:`unseen_day`'s note for the first day of the series (in the map's zone) on a kind
    of day the map never saw; None when it saw every kind the series reaches. One look per
    day of the week (the kinds are weekdays and weekends, or the days of the week)."""
    import numpy as np

    from aion_cli.engine.temporal.calendar import weekday_of

    weekdays = weekday_of(calendar.day(list(times_ns)))
    _, first_of_weekday = np.unique(weekdays, return_index=True)
    for i in sorted(first_of_weekday.tolist()):
        note = unseen_day(manifest, int(times_ns[i]), shown, times_ns)
        if note is not None:
            return note
    return None


def _weekday_in(t_ns: int, shown: Zone | None) -> int:
    """The day of the week (Monday 0) of ``t_ns`` in the zone ``shown`` (None: UTC)."""
    from aion_cli.engine.time_text import utc_of

    return (utc_of(t_ns) if shown is None else utc_of(t_ns).astimezone(shown.tz)).weekday()


_NO_LOG = "no log observed "


def _unobserved_hour(manifest: Manifest, t_ns: int) -> str | None:
    """The note for a time of day no log observed on any day (a tracker recorded only in
    working hours, say): each entry's forecast there is extrapolated from the hours it saw.
    None when some kind of day observed that hour (another kind's forecast follows it: see
    :func:`unseen_day`), or for a map that does not list its observed bins (older maps)."""
    observed = hour_observed(manifest, [t_ns])
    calendar = calendar_of(manifest.config, manifest.timezone)
    if observed is None or observed[0] or calendar is None:
        return None
    per_day = calendar.bins_per_day
    at = int(calendar.profile_bin(t_ns)) % per_day
    return (
        f"{_NO_LOG}{words.clock(at, calendar.bin_s)}-{words.clock(at + 1, calendar.bin_s)} "
        f"({calendar.timezone}) on any day (the map observed "
        f"{words.clock_ranges(hours_of(manifest, per_day), calendar.bin_s)}): the forecast at "
        f"this hour is extrapolated from the hours observed, not measured: {STATIC_THERE}"
    )
