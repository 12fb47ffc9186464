"""What ``aion convert`` says about the data it converted: the note on times read in UTC (and
the zone of a dataset recorded in a known place), and the warnings on people walking too fast
for the frame rate, a ``t_ns`` column in another unit, stray times and ``--observed`` spans
apart from the detections. The log is written as the file has it either way.

Split from :mod:`aion_cli.cli.convert`; the command there calls these."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aion_cli.cli.convert_checks import FRAME_LAYOUTS, RELATIVE_LAYOUTS
from aion_cli.errors import path_word
from aion_cli.number_text import counted


def note_utc_times(
    layout: str, output: Path, start: bool, observed: bool, doubted: bool = False
) -> None:
    """Without ``--tz``: a note naming the times read in UTC (``--date``, ``--start``,
    ``--observed`` given as clock times, not UNIX ones) and, for a dataset recorded in a known
    place, its zone and what makes a map of local hours (times typed on the place's clock:
    converting again with ``--tz``; else ``aion build --tz``); ETH / UCY (recorded in several
    places) get the first part alone. Not for a file whose times count from 0 without
    ``--start``: no zone gives 1970's hours a meaning, the note on ``--start`` says so.
    ``doubted``: the file looks like another layout (a warning said so), whose place is not
    asserted: the first part alone, as for ETH / UCY."""
    from aion_cli.cli.console import note

    given = [name for name, used in (
        ("--date", layout == "edinburgh"), ("--start", start), ("--observed", observed)) if used]
    read = (f" {' and '.join(given)} {'was' if len(given) == 1 else 'were'} read in UTC "
            "(give --tz)") if given else ""
    home_known = layout in HOME_ZONES and not doubted
    if home_known and given:
        # times typed on the place's clock are an hour or more off: the build's --tz cannot
        # mend them, converting again with --tz reads them right (and the log carries it)
        place, home = HOME_ZONES[layout]
        it = "it is" if len(given) == 1 else "they are"
        note(
            f"{layout}: the dataset was recorded in {place} ({home}):{read}: if {it} "
            f"{place}'s clock, convert again with --tz {home} (the log then carries the zone, "
            f"which aion build follows); if {it} UTC, aion build {path_word(output)} --tz "
            f"{home} makes a map of {place}'s days and hours"
        )
    elif home_known:
        place, home = HOME_ZONES[layout]
        note(
            f"{layout}: the dataset was recorded in {place} ({home}): aion build takes a "
            f"map's days and hours in UTC unless told: aion build {path_word(output)} "
            f"--tz {home}"
        )
    elif given and (layout in RELATIVE_LAYOUTS or doubted):
        note(f"{layout}:{read}")


def read_on_a_clock(text: str) -> bool:
    """Whether the time ``text`` (an option's, already read once) names a wall-clock time the
    zone places (``2026-01-05 12:00``, ``tomorrow 12:00``), not an instant no zone changes: a
    UNIX time, ``now`` or relative to it (``-2h``), a time with its offset or zone
    (``2026-01-05T12:00+01:00``). Read in two zones at one fixed moment, it differs."""
    from datetime import UTC, datetime

    from aion_cli.errors import AionError
    from aion_cli.timeparse import parse_time, resolve_zone

    moment = datetime(2026, 1, 5, 12, tzinfo=UTC)
    try:
        return parse_time(text, resolve_zone("UTC"), moment) != parse_time(
            text, resolve_zone("+05:00"), moment
        )
    except AionError:  # a form only its span reads (an end of a clock alone): on a clock
        return True


#: where each layout's dataset was recorded, and its zone: the hours of the day a map of it
#: means are local ones (ATC's 09:00-21:00 are Osaka's, 00:00-12:00 UTC)
HOME_ZONES = {
    "atc": ("Osaka", "Asia/Tokyo"),
    "lincoln": ("Lincoln, UK", "Europe/London"),
    "edinburgh": ("Edinburgh", "Europe/London"),
    "thor": ("Örebro", "Europe/Stockholm"),
    "thor-magni": ("Örebro", "Europe/Stockholm"),
}


FAST_WALK_MPS = 2.0
"""A mean walking speed above this (people walk about 1.3 m/s) says a frame-numbered file's
frame rate is not the one assumed."""


def warn_fast_walkers(speed: Any, layout: str, fps: float | None) -> None:
    """A warning when the people of a frame-numbered file walk faster (the median of their
    speeds) than :data:`FAST_WALK_MPS` at the frame rate used: frames annotated at another
    rate than the default (the Social-GAN copy of ETH's biwi_eth.txt is 15 fps, not 25) make
    everyone fast. The median, not the mean: one damaged position (1e300 m) made the mean
    "9493670886...m/s" and the rate advised 1e-300 fps."""
    import numpy as np

    from aion_cli.cli.console import warn

    moving = speed[np.isfinite(speed) & (speed > 0)]
    if moving.size == 0:
        return
    typical = float(np.median(moving))
    if typical > FAST_WALK_MPS:
        rate = fps or FRAME_LAYOUTS[layout]
        warn(
            f"people walk {typical:.2f} m/s (median) at {rate:g} frames per second, where "
            f"walking is about 1.3 m/s: if the file's frames are another rate, give --fps "
            f"(at {rate * 1.3 / typical:.3g} fps they would walk 1.3 m/s)"
        )


#: what canonical t_ns values that are really seconds / ms / µs since 1970 look like: the
#: span of 1973-03-03 .. 2096-10-02 in that unit (disjoint from each other and from ns)
_OTHER_UNITS = (("seconds", 10**9, "1e9"), ("milliseconds", 10**6, "1e6"),
                ("microseconds", 10**3, "1e3"))


def warn_time_unit(name: str, first_ns: int, last_ns: int | None) -> None:
    """A warning when a canonical file's ``t_ns`` column holds UNIX seconds, milliseconds or
    microseconds, not nanoseconds: every detection then lies in 1970 (1351038020 "ns" is
    1970-01-01 00:00:01; as seconds, ATC's 2012-10-24 00:20:20 UTC)."""
    from aion_cli.cli.console import warn
    from aion_cli.engine.time_text import format_ns
    from aion_cli.timeparse import resolve_zone

    last = first_ns if last_ns is None else last_ns
    for unit, scale, factor in _OTHER_UNITS:
        if first_ns * scale >= 1e17 and last * scale < 4e18:
            utc = resolve_zone("UTC")
            warn(
                f"{name}: t_ns starts at {first_ns}: as nanoseconds {format_ns(first_ns, utc)}, "
                f"as UNIX {unit} {format_ns(first_ns * scale, utc)}: the canonical t_ns column "
                f"is nanoseconds since 1970 (multiply it by {factor}); written as the file has it"
            )
            return


def warn_stray_times(name: str, times: Any, zone: Any) -> None:
    """A warning when a few messages lie more than a day away from the others' times
    (:func:`aion_cli.log_times.stray_mask`, the rule by which ``aion build`` drops them): a
    damaged time (an ATC row's ``1351`` cut from ``1351038020``) made the log span decades."""
    from aion_cli.cli.console import warn
    from aion_cli.engine.time_text import format_ns
    from aion_cli.log_times import stray_mask

    stray = stray_mask(times)
    if stray.any():
        n = int(stray.sum())
        warn(
            f"{name}: {counted(n, 'message')} of the log {'lies' if n == 1 else 'lie'} more "
            f"than a day away from the others (first: {format_ns(int(times[stray][0]), zone)}):"
            " a damaged time in the file? Written as the file has it, but aion build leaves "
            f"{'it' if n == 1 else 'them'} out (docs/ROBUSTNESS.md, time sanity)"
        )


def warn_spans_without_detections(
    texts: tuple[str, ...], spans: list[tuple[int, int]], summary: Any, zone: Any
) -> None:
    """A warning for each ``--observed`` span (``texts`` as typed) that lies apart from the
    detections (:func:`aion_cli.times_apart.span_apart`: wholly before the first or after the
    last, or reaching more than a week and the detections' own span beyond them): most
    likely a span typed in the wrong zone, hour or year (it is still written: a sensor may
    well have recorded nobody then)."""
    from aion_cli.cli.console import warn
    from aion_cli.times_apart import observed_apart_warnings

    first, last = summary.first_detection_ns, summary.last_detection_ns
    for line in observed_apart_warnings(texts, spans, first, last, zone, "the detections"):
        warn(line)
