"""``aion convert``: public pedestrian-track datasets (CSV) -> robot logs aion can build from."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.common import AionPath, parse_span, quiet_option, span_start_notes
from aion_cli.cli.convert_checks import (
    FRAME_LAYOUTS,
    RELATIVE_LAYOUTS,
    check_layout_options,
    check_start_applies,
    check_tracks_input,
    container_for,
)
from aion_cli.cli.convert_notes import (
    HOME_ZONES,
    note_utc_times,
    read_on_a_clock,
    warn_fast_walkers,
    warn_spans_without_detections,
    warn_stray_times,
    warn_time_unit,
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
    changed: str | None = None
    clock = date_text if layout == "edinburgh" else start_text
    if layout == "edinburgh" and clock is not None and clock.strip().lower() in DAY_WORDS:
        clock = f"{clock} 00:00"  # --date names a day: its midnight ("yesterday" alone is now-1d)
    if clock is not None:
        option = "--date" if layout == "edinburgh" else "--start"
        try:
            start_ns = parse_time(clock, zone)
        except TimeFormatError as exc:  # name the option, as --observed's errors do
            raise InputError(f"{option} {clock!r}: {exc.message}", hint=exc.hint) from exc
        from aion_cli.wall_clock import clock_change_note

        # a start a clock change skips or repeats: which instant it was read as (as --time
        # says), noted once the log is written so that an error stays a failure's one output
        changed = clock_change_note(clock, zone, start_ns)
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
                warn_fast_walkers(data.batch.speed, layout, fps)
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
    if changed is not None:
        note(f"{'--date' if layout == 'edinburgh' else '--start'} {changed}")
    for line in span_start_notes(observed_text, spans, zone, "--observed"):
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
        home = None if mismatch is not None else HOME_ZONES.get(layout)  # doubted: not said
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
        # the empty ones the "observed:" line counts, so that the two add up
        + (f"(and {summary.observed_messages:,} empty) " if summary.observed_messages else "")
        + f"over {span:,.0f} s"
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
    warn_stray_times(tracks.name, summary.topic_times, zone)
    for text in summary.graph_notes:  # a graph file read leniently: what was skipped
        note(text)
    if summary.graph_agents_dropped:
        note(
            f"{graph_file}: its agent layer ({summary.graph_agents_dropped:,} robot "
            "poses of the graph's own recording) is left out of the log: a dataset has no "
            "robot, so the build observes with the log's messages and --observed spans"
        )
    warn_spans_without_detections(observed_text, spans, summary, zone)
    if layout == "canonical" and summary.first_detection_ns is not None:
        warn_time_unit(tracks.name, summary.first_detection_ns, summary.last_detection_ns)
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
        on_clock = [t for t in observed_text if any(map(read_on_a_clock, t.split("..")))]
        start_on_clock = start_text is not None and read_on_a_clock(start_text)
        if not from_zero:  # the note above says what to give: --start
            note_utc_times(
                layout, output, start_on_clock, bool(on_clock), doubted=mismatch is not None
            )
