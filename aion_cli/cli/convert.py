"""``aion convert``: public pedestrian-track datasets (CSV) -> robot logs aion can build from."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.common import AionPath, parse_span, quiet_option
from aion_cli.cli.convert_checks import (
    FRAME_LAYOUTS,
    RELATIVE_LAYOUTS,
    check_layout_options,
    check_start_applies,
    check_tracks_input,
    container_for,
)
from aion_cli.cli.output import AionCommand, AnyCase, markup_safe
from aion_cli.errors import path_word
from aion_cli.number_text import counted

EPILOG = """\b
Examples:
  aion convert atc-20121024.csv --layout atc -o atc.mcap \\
      --observed "2012-10-24 09:00..2012-10-24 21:00" --tz Asia/Tokyo
  aion convert thor_run1.csv --layout thor -o thor.mcap --graph dsg.json
  tail -n +4 2017-06-09.txt > rows.txt          its rows, not its header's 4 days
  aion convert rows.txt --layout lincoln --tz Europe/London -o lincoln.mcap
  aion convert tracks.01Jul.txt --layout edinburgh --date 2010-07-01 --tz Europe/London \\
      -o forum.mcap
  aion convert THOR-Magni_120522_SC1A_R1.csv --layout thor-magni \\
      --start "2022-05-12 10:00" --tz Europe/Stockholm -o magni.mcap
  aion convert students003.txt --layout ucy -o ucy.mcap --start "2026-01-05 12:00"
  aion convert tracks.csv -o tracks.mcap            canonical columns (the default)
  aion build atc.mcap --derive-graph                then learn a map from it

\b
Layouts: canonical (t_ns, track_id, x, y, z, heading_rad, speed_mps), atc (ATC shopping
centre), thor (THÖR), thor-magni (THÖR-MAGNI CSV: Time, ag_id, x, y in mm; only the
Helmet_N people), eth / ucy (4 columns frame ped_id x y: 25 fps frame numbers, 0.4 s apart;
--fps 15 for the 10-frame biwi_eth.txt of the Social-GAN / Trajectron++ sets), lincoln
(L-CAS corridor detections without ids: linked into tracks; every variant is recognised by
its content), edinburgh (Informatics Forum TRACK.Rn entries: pixels at 24.7 mm, frames at
about 9 fps; --date says when frame 0 was, midnight unless a time is given).

\b
The tracks become people-detection messages. A dataset has no robot, so the build treats
it as a fixed sensor that observed only the 10-minute windows in which the log holds a
message: give the spans the sensor was recording with --observed START..END (repeatable)
and empty detection messages are written over them every 30 s, as a running tracker would
publish them. The lincoln layout adds the spans its files declare. Without any span,
windows without a detection count as not observed.
"""


CONTAINERS = ("mcap", "mcap-ros1", "bag", "rosbag2-sqlite3", "rosbag2-mcap")
#: formats.track_types.LAYOUTS, spelt out so that `aion --help` need not import numpy
DAY_WORDS = ("today", "tomorrow", "yesterday")
"""Day words that alone mean now shifted by whole days (GNU date's rule, aion_cli.timeparse);
``--date`` takes them as the day, frame 0 at its midnight, as ``--date 2010-07-01``."""

LAYOUTS = ("canonical", "atc", "thor", "thor-magni", "eth", "ucy", "lincoln", "edinburgh")
@click.command(
    "convert",
    short_help="Turn pedestrian-track CSVs into logs.",
    cls=AionCommand,
    epilog=EPILOG,
    advanced=("container", "msgtype", "drop_ids", "start_text", "tz", "fps", "length_unit"),
)
@click.argument("tracks", type=AionPath(path_type=Path))
@click.option(
    "-o",
    "--output",
    required=True,
    type=AionPath(path_type=Path),
    help="Log to write: .mcap, .bag, or a rosbag2 folder (no suffix).",
)
@click.option(
    "--layout",
    type=click.Choice(LAYOUTS, case_sensitive=False),
    default="canonical",
    show_default=True,
    help="Column layout of the CSV.",
)
@click.option(
    "--date",
    "date_text",
    metavar="DAY",
    help="edinburgh: the day of the file (it has frame numbers, no clock), e.g. 2010-07-01 "
    '(frame 0 at midnight) or "2010-07-01 08:00" (frame 0 then).',
)
@click.option(
    "--graph",
    "graph_file",
    type=AionPath(path_type=Path, dir_okay=False),
    help="Scene graph (dsg.json, .sparkdsg) to publish in the log as well: with the first "
    "detection message and then about once a minute with the detections (never where the log "
    "has none, so it makes no time observed).",
)
@click.option(
    "--container",
    type=click.Choice([*CONTAINERS, "rosbag2"], case_sensitive=False),
    # aion simulate --format names the rosbag2 folder of MCAP storage rosbag2
    callback=lambda _ctx, _param, value: "rosbag2-mcap" if value == "rosbag2" else value,
    help="Log container (rosbag2 is rosbag2-mcap, as in aion simulate) [default: from the "
    "output's suffix].",
)
@click.option(
    "--message-type",
    "msgtype",
    type=AnyCase(["spencer_tracking_msgs/msg/TrackedPersons", "geometry_msgs/msg/PoseArray"]),
    default="spencer_tracking_msgs/msg/TrackedPersons",
    show_default=True,
    help="Message type the detections are written as.",
)
@click.option(
    "--drop-ids",
    is_flag=True,
    help="Write the detections as an id-less detector publishes them (a leg detector): "
    "geometry_msgs/msg/PoseArray without track ids or orientations, so aion build links them "
    "into tracks for their directions (to test its linker against the file's own tracks).",
)
@click.option(
    "--start",
    "start_text",
    metavar="T",
    help="When the recording began: THÖR / THÖR-MAGNI / ETH / UCY times count from 0 and are "
    "shifted to start at this time (ATC, Lincoln and canonical times are absolute already).",
)
@click.option(
    "--fps",
    type=float,
    metavar="HZ",
    help="Frame rate of frame numbers: eth / ucy [default: 25], edinburgh [default: 9].",
)
@click.option(
    "--length-unit",
    "length_unit",
    type=click.Choice(["auto", "mm", "m"], case_sensitive=False),
    help="thor-magni: unit of x, y, z [default: auto: millimetres when the positions span or "
    "reach more than 200 units from the origin, as the dataset's files do].",
)
@click.option(
    "--observed",
    "observed_text",
    metavar="START..END",
    multiple=True,
    help="A span the sensor was recording (repeatable), e.g. "
    '"2017-06-09 09:00..2017-06-09 18:30" or "1496999627..1497032025": written as empty '
    "detection messages every 30 s (as a running tracker publishes) and recorded in the "
    "log, which aion build takes as its --observed spans.",
)
@click.option(
    "--tz",
    metavar="ZONE",
    help="Time zone for --observed / --start / --date times without an offset: IANA name, UTC, "
    "+01:00, local (the machine's) [default: UTC, as aion build reads --observed]. Written "
    "into the log: aion build follows it without --tz.",
)
@click.option("--force", is_flag=True, help="Overwrite the output if it exists.")
@quiet_option
def command(
    tracks: Path,
    output: Path,
    layout: str,
    date_text: str | None,
    graph_file: Path | None,
    container: str | None,
    msgtype: str,
    drop_ids: bool,
    start_text: str | None,
    fps: float | None,
    length_unit: str | None,
    observed_text: tuple[str, ...],
    tz: str | None,
    force: bool,
) -> None:
    """Convert the pedestrian tracks in TRACKS (CSV) into a log with people detections."""
    from aion_cli.cli.common import option_given
    from aion_cli.cli.console import console, note, warn
    from aion_cli.engine.types import DetectionBatch
    from aion_cli.errors import InputError
    from aion_cli.formats.track_csv import STREAM_LAYOUTS
    from aion_cli.formats.track_sniff import UNIX_SECONDS_FROM as UNIX_S
    from aion_cli.formats.track_sniff import layout_mismatch
    from aion_cli.formats.track_tail import cut_last_line, negative_id_line
    from aion_cli.formats.track_types import (
        FAR_M,
        NegativeTrackIdError,
        NoTrackRowsError,
        merge_spans,
    )
    from aion_cli.formats.tracks import read_track_data
    from aion_cli.formats.tracks_log import POSE_ARRAY, stream_tracks_to_log, tracks_to_log
    from aion_cli.formats.writers import check_log_target
    from aion_cli.timeparse import TimeFormatError, parse_time, resolve_zone

    check_tracks_input(tracks)
    kind = container_for(output, container)
    # the target is refused (exists, device, FIFO, not aion's own log) before anything is read
    check_log_target(output, kind, overwrite=force)
    if start_text is not None:
        check_start_applies(tracks, layout)
    check_layout_options(layout, date_text, start_text, fps, length_unit)
    # UTC unless --tz: the zone aion build reads the same --observed in (and a map's default),
    # never the machine's, which made one span two spans on a machine outside UTC
    zone = resolve_zone("UTC" if tz is None else tz)
    # bad spans fail before reading
    spans = [parse_span(text, zone, "--observed") for text in observed_text]
    start_ns = 0
    clock = date_text if layout == "edinburgh" else start_text
    if layout == "edinburgh" and clock is not None and clock.strip().lower() in DAY_WORDS:
        clock = f"{clock} 00:00"  # --date names a day: its midnight ("yesterday" alone is now-1d)
    if clock is not None:
        option = "--date" if layout == "edinburgh" else "--start"
        try:
            start_ns = parse_time(clock, zone)
        except TimeFormatError as exc:  # name the option, as --observed's errors do
            raise InputError(f"{option} {clock!r}: {exc.message}", hint=exc.hint) from exc
    if drop_ids and option_given("msgtype") and msgtype != POSE_ARRAY:
        raise InputError(
            f"--drop-ids writes {POSE_ARRAY}, not {msgtype}", hint="drop --message-type"
        )
    options: dict[str, Any] = {
        "graph_file": graph_file, "container": kind, "overwrite": force, "headings": not drop_ids,
        "msgtype": POSE_ARRAY if drop_ids else msgtype,
        # the log carries --tz, so aion build follows it without being told again
        "timezone": zone.name if tz is not None else None,
    }
    notes: tuple[str, ...] = ()
    try:
        if layout in STREAM_LAYOUTS:  # one detection per line: read and written in chunks
            summary = stream_tracks_to_log(
                tracks, output, layout, start_ns, observed=merge_spans(spans), **options
            )
        else:
            data = read_track_data(
                tracks, layout, start_ns=start_ns, fps=fps, units=length_unit or "auto"
            )
            if len(data.batch) == 0:
                raise InputError(
                    f"no tracks in {tracks}", hint=f"is it really the {layout!r} layout?"
                )
            summary = tracks_to_log(
                data.batch, output, observed=merge_spans([*data.observed, *spans]), **options
            )
            notes = data.notes
            if layout in FRAME_LAYOUTS:
                _warn_fast_walkers(data.batch.speed, layout, fps)
    except NegativeTrackIdError as exc:  # the writer saw the id: name the file's line of it
        where = negative_id_line(tracks, layout)
        raise InputError(
            f"{tracks}: {where}: TrackedPersons needs track ids of 0 or more" if where
            else f"{tracks}: {exc.message}",
            hint=exc.hint,
        ) from exc
    except NoTrackRowsError as exc:
        if not spans and not exc.declared:  # without spans there is nothing to write
            raise
        # the sensor ran while nobody came: the log marks the declared spans only
        nobody = DetectionBatch.from_arrays([], [])
        marked = merge_spans([*spans, *exc.declared])
        summary = tracks_to_log(nobody, output, observed=marked, **options)
        which = "the --observed spans" if not exc.declared else (
            "its header's declared span" + (" and the --observed spans" if spans else ""))
        note(f"{exc.message}: the log marks {which} only (nobody came)")
    for line in notes:
        note(line)
    mismatch = layout_mismatch(tracks, layout)
    if mismatch is not None:
        warn(mismatch)
    cut = cut_last_line(tracks, layout)
    if cut is not None:
        warn(cut)
    if layout == "edinburgh":
        from aion_cli.engine.time_text import format_ns

        note(
            f"edinburgh: frame 0 taken as {format_ns(start_ns, zone)}, frames at "
            f"{fps or FRAME_LAYOUTS['edinburgh']:g} fps (the file has no clock time)"
        )
    from_zero = layout in RELATIVE_LAYOUTS and start_text is None \
        and summary.start_ns < 1e9 * UNIX_S
    if from_zero:  # no zone gives 1970's hours a meaning: --start (and its zone) does
        home = HOME_ZONES.get(layout)
        note(
            f"{layout}: the file's times count from 0 and were written from 1970-01-01 00:00 "
            "UTC; give --start for when it was recorded"
            + (f" (the dataset was recorded in {home[0]}: --start \"YYYY-MM-DD HH:MM\" --tz "
               f"{home[1]} reads it on {home[0]}'s clock, and the log carries the zone)"
               if home else "")
        )
    span = (summary.end_ns - summary.start_ns) / 1e9
    console().print(
        f"wrote {markup_safe(summary.path)}: {counted(summary.detections, 'detection')} of "
        f"{counted(summary.tracks, 'track')} in {counted(summary.detection_messages, 'message')} "
        f"over {span:,.0f} s"
        + (" (without ids or orientations: aion build links them)" if drop_ids else "")
        + (f", {summary.graph_messages} scene-graph messages" if summary.graph_messages else ""),
        soft_wrap=True,
    )
    if summary.repeated_rows:  # copies: the file's fault (a warning); moves: its tracker's
        moved = summary.repeated_elsewhere
        copies = summary.repeated_rows - moved
        (warn if copies else note)(
            f"{tracks.name}: {counted(summary.repeated_rows, 'row')} "
            f"{'repeats' if summary.repeated_rows == 1 else 'repeat'} the time and track "
            f"id of an earlier row ({copies:,} the same row again, {moved:,} at another "
            "position): left out, so each person counts once per time"
            + (" (does the file hold rows twice?)" if copies else
               " (the tracker gave a person two positions at one time)")
        )
    if summary.far_rows:
        warn(
            f"{tracks.name}: {counted(summary.far_rows, 'row')} "
            f"{'lies' if summary.far_rows == 1 else 'lie'} more than "
            f"{FAR_M / 1000:,.0f} km from the origin (e.g. {summary.far_example:g} m): damaged "
            "values, or positions not in metres; written as the file has them, but aion build "
            "leaves them out (its spatial hash ends there at the default cell_size)"
        )
    _warn_stray_times(tracks.name, summary.topic_times, zone)
    for text in summary.graph_notes:  # a graph file read leniently: what was skipped
        note(text)
    if summary.graph_agents_dropped:
        note(
            f"{graph_file}: its agent layer ({summary.graph_agents_dropped:,} robot "
            "poses of the graph's own recording) is left out of the log: a dataset has no "
            "robot, so the build observes with the log's messages and --observed spans"
        )
    _warn_spans_without_detections(observed_text, spans, summary, zone)
    if layout == "canonical" and summary.first_detection_ns is not None:
        _warn_time_unit(tracks.name, summary.first_detection_ns, summary.last_detection_ns)
    if summary.observed_spans:
        console().print(
            f"observed: {summary.observed_spans} span(s), {summary.observed_ns / 3.6e12:,.2f} h, "
            f"marked by {summary.observed_messages:,} empty detection messages (every 30 s)",
            soft_wrap=True,
        )
    else:
        note(
            "no observed spans: the build counts only windows with a detection as observed; "
            "give the spans the sensor was recording with --observed START..END"
        )
    if tz is not None and zone.name != "UTC":
        # the log carries the zone: aion build takes it unless its own --tz says otherwise
        note(
            f"the log carries the zone {zone.name}: aion build {path_word(output)} makes a "
            f"map whose days and hours of the day are {zone.name}'s without --tz"
        )
    elif tz is None:
        from aion_cli.timeparse import is_unix_time

        on_clock = [t for t in observed_text if not all(map(is_unix_time, t.split("..")))]
        if not from_zero:  # the note above says what to give: --start
            _note_utc_times(layout, output, start_text is not None, bool(on_clock))


def _note_utc_times(layout: str, output: Path, start: bool, observed: bool) -> None:
    """Without ``--tz``: a note naming the times read in UTC (``--date``, ``--start``,
    ``--observed`` given as clock times, not UNIX ones) and, for a dataset recorded in a known
    place, its zone and what makes a map of local hours (times typed on the place's clock:
    converting again with ``--tz``; else ``aion build --tz``); ETH / UCY (recorded in several
    places) get the first part alone. Not for a file whose times count from 0 without
    ``--start``: no zone gives 1970's hours a meaning, the note on ``--start`` says so."""
    from aion_cli.cli.console import note

    given = [name for name, used in (
        ("--date", layout == "edinburgh"), ("--start", start), ("--observed", observed)) if used]
    read = (f" {' and '.join(given)} {'was' if len(given) == 1 else 'were'} read in UTC "
            "(give --tz)") if given else ""
    if layout in HOME_ZONES and given:
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
    elif layout in HOME_ZONES:
        place, home = HOME_ZONES[layout]
        note(
            f"{layout}: the dataset was recorded in {place} ({home}): aion build takes a "
            f"map's days and hours in UTC unless told: aion build {path_word(output)} "
            f"--tz {home}"
        )
    elif given and layout in RELATIVE_LAYOUTS:
        note(f"{layout}:{read}")


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


def _warn_fast_walkers(speed: Any, layout: str, fps: float | None) -> None:
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


def _warn_time_unit(name: str, first_ns: int, last_ns: int | None) -> None:
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


def _warn_stray_times(name: str, times: Any, zone: Any) -> None:
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


def _warn_spans_without_detections(
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
