"""Options and helpers shared by the commands that read a map (predict, plan, export)."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import click

from aion_cli.engine.time_text import Zone, format_ns
from aion_cli.time_steps import parse_step
from aion_cli.timeparse import parse_time, resolve_zone

F = TypeVar("F", bound=Callable[..., Any])

TIME_HELP = (
    'When: "2026-11-23 08:30", "2026-11-23T08:30:00+01:00", "2026-11-23 08:30 Europe/Berlin", '
    'UNIX seconds, "now", "+2h", "-30m", "today 17:00", "tomorrow 12:00", "yesterday 08:30", '
    '"monday 08:30".'
)
"""The forms ``--time`` reads, for its help; each day word of ``timeparse.DAY_SHIFTS``."""

STEP_HELP = (
    "1h, 30m, 600s (elapsed time), or 1d, 1w (calendar days in the zone: the same "
    "wall-clock time every day, across a daylight-saving change)"
)
"""What ``--step`` reads, for its help (``predict``, ``export``, ``plan``)."""


class AionPath(click.Path):
    """``click.Path`` that refuses an empty value: ``Path("")`` is the current folder, so an
    unset shell variable (``aion build "$LOG"``) would otherwise read or write "here"; and
    ``-``, which aion does not read or write as standard input or output: ``aion compact
    MAP -o - > robot.aion`` wrote the map to a file named ``-`` and left ``robot.aion``
    empty, with success."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, str) and not value.strip():
            self.fail(
                "an empty path (an unset shell variable?): name the file or folder "
                "('.' for the current folder)",
                param,
                ctx,
            )
        if value == "-":
            self.fail(
                "'-' is not standard input or output here: aion reads and writes named files "
                "and folders; name one ('./-' for a file called '-')",
                param,
                ctx,
            )
        if isinstance(value, str) and not self.dir_okay and value.endswith(("/", os.sep)):
            # Path() drops the separator: x.ply/ would quietly write the file x.ply
            self.fail(
                f"{value!r} ends in '/', which names a folder: give a file name", param, ctx
            )
        if isinstance(value, str) and not self.dir_okay and os.path.isdir(value):
            if _is_bag_folder(value):  # "name a file in it" would put a map into a log
                self.fail(f"{value!r} is a rosbag2 bag folder (a log), not a file", param, ctx)
            # click's own "File '.' is a directory." leaves the way out unsaid
            here = os.path.realpath(value) == os.path.realpath(os.curdir)
            self.fail(
                f"{value!r} is {'the current folder' if here else 'a folder'}, not a file: name "
                f"a file in it (e.g. {_file_in(value)}){_OR_ANOTHER * bool(_suffix(value))}",
                param,
                ctx,
            )
        return super().convert(value, param, ctx)


def _file_in(folder: str) -> str:
    """A file in ``folder`` to name instead of it, with the file ending its name has (a folder
    ``maps.aion`` given as ``-o``: ``maps.aion/map.aion``; ``maps.aion/NAME`` had named a file
    without the ending)."""
    suffix = _suffix(folder)
    if not suffix:
        return os.path.join(folder, "NAME")
    name = f"map{suffix}" if suffix.lower() == ".aion" else f"NAME{suffix}"
    return os.path.join(folder, name)


def _suffix(folder: str) -> str:
    """The file ending of the name ``folder`` has (``.aion``), '' for none."""
    suffix = os.path.splitext(os.path.basename(folder.rstrip("/" + os.sep)))[1]
    return "" if suffix == os.extsep else suffix


_OR_ANOTHER = " or another name for the file"
"""Said after the file in a folder whose name ends like a file's: the user meant a file."""


def _is_bag_folder(path: str) -> bool:
    """Whether the folder ``path`` is a rosbag2 bag, as ``ros2 bag record`` writes one: with
    its ``metadata.yaml`` (a folder of loose ``.mcap`` logs is not called one)."""
    return os.path.isfile(os.path.join(path, "metadata.yaml"))


def option_given(name: str) -> bool:
    """Whether the current command's parameter ``name`` was given on the command line (or in
    the environment), not left at its default: ``--time`` beside ``--from`` or ``--leave``."""
    source = click.get_current_context().get_parameter_source(name)
    return source not in (click.core.ParameterSource.DEFAULT, None)


def map_argument(func: F) -> F:
    """The MAP positional argument (existence is checked by ``load_map`` with a clear error)."""
    return click.argument("map_path", metavar="MAP", type=AionPath(path_type=Path))(func)


def tz_option(func: F) -> F:
    """``--tz``: the zone for times without an offset."""
    return click.option(
        "--tz",
        metavar="ZONE",
        help="Time zone for times without an offset: IANA name, UTC, +01:00, local (the machine's) "
        "[default: the map's zone: UTC unless aion build --tz gave another].",
    )(func)


def quiet_option(func: F) -> F:
    """``-q``: nothing on stderr but warnings and errors (no notes, time line, summary or
    closing message), for scripts and cron jobs; the data on stdout and the files are the
    same."""

    def _set(ctx: click.Context, param: click.Parameter, value: bool) -> bool:
        from aion_cli.cli.console import set_quiet

        set_quiet(bool(value))
        return bool(value)

    return click.option(
        "-q",
        "--quiet",
        is_flag=True,
        expose_value=False,
        callback=_set,
        help="No progress, notes, summaries or closing messages on stderr (warnings and "
        "errors stay).",
    )(func)


def map_zone(tz: str | None, loaded: Any = None) -> Zone:
    """The zone ``tz``; without it, the zone the map was built for (UTC unless ``build --tz``
    gave another), else (no map, or one that records no zone) the machine's local zone (see
    :mod:`aion_cli.timeparse`)."""
    if tz is None and loaded is not None:
        from aion_cli.manifest import Manifest

        tz = Manifest.from_dict(loaded.manifest).timezone
    return resolve_zone(tz)


def resolve_time(
    text: str,
    tz: str | None,
    loaded: Any = None,
    after_ns: int | None = None,
    option: str = "--time",
) -> tuple[int, Zone]:
    """Parse ``text`` in :func:`map_zone`'s zone; the time and the zone. ``after_ns``: the
    start of the span ``text`` ends, which a clock alone or a relative form is read from
    (``--from "2026-11-23 08:00" --to 18:00`` ends that day, not today). A time that cannot
    be read is a :class:`~aion_cli.timeparse.TimeFormatError` naming ``option``, as
    ``--observed`` and ``--leave`` name theirs."""
    from aion_cli.timeparse import TimeFormatError

    zone = map_zone(tz, loaded)
    try:
        return parse_time(text, zone, start=_reference(after_ns, zone)), zone
    except TimeFormatError as exc:
        raise TimeFormatError(f"{option} {text!r}: {exc.message}", exc.hint) from exc


def _reference(start_ns: int | None, zone: Zone) -> Any:
    """The moment an end's clock-only, day-word or relative form counts from: its span's
    start (None: now); ``now`` itself is the current time still (``parse_time``)."""
    from aion_cli.engine.time_text import from_ns

    return None if start_ns is None else from_ns(start_ns, zone)


def announce_time(
    t_ns: int,
    zone: Zone,
    label: str = "time",
    loaded: Any = None,
    series: list[int] | None = None,
    noun: str = "times",
    text: str | None = None,
) -> None:
    """Say on stderr which time and zone were used (after the command succeeded, so an error
    stays the only output of a failed command), which instant ``text`` (what the user typed)
    was read as where a clock change skips or repeats it (:mod:`aion_cli.wall_clock`), and,
    for a forecast from the map ``loaded``, what it cannot say at that time
    (:mod:`aion_cli.forecast_notes`) and at the hours of the ``series`` of times it belongs
    to (a series, the departures of ``plan --leave``: ``noun`` says which)."""
    from aion_cli.cli.console import note
    from aion_cli.wall_clock import clock_change_note

    note(f"{label}: {format_ns(t_ns, zone)} ({zone.name})")
    changed = None if text is None else clock_change_note(text, zone, t_ns)
    if changed is not None:
        note(changed)
    if loaded is not None:
        from aion_cli.forecast_notes import forecast_notes, series_notes
        from aion_cli.manifest import Manifest

        manifest = Manifest.from_dict(loaded.manifest)
        lines = (
            series_notes(manifest, series, t_ns, noun, zone)
            if series
            else forecast_notes(manifest, t_ns, noun, zone)
        )
        for line in lines:
            note(line)


def note_empty(loaded: Any) -> None:
    """Say on stderr that the map ``loaded`` holds no entries, if so
    (:func:`aion_cli.forecast_notes.empty_map`; :func:`announce_time` says it of a forecast)."""
    from aion_cli.cli.console import note
    from aion_cli.forecast_notes import empty_map
    from aion_cli.manifest import Manifest

    said = empty_map(Manifest.from_dict(loaded.manifest))
    if said is not None:
        note(said)


def load(map_path: Path) -> Any:
    """Read a map for a query (``aion_cli.mapquery.load_map``): without the Fourier sums
    when the map stores the FreMEn components its forecasts use."""
    from aion_cli.mapquery import load_map

    return load_map(map_path, forecast_only=True)


def load_config(path: Path | None) -> Any:
    """The ``ModelConfig`` of ``--config FILE`` (None without one); a file that cannot be
    read, is not TOML text or holds bad parameters is a ``ConfigError`` (build, evaluate)."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.formats.toml_files import read_toml_text

    if path is None:
        return None
    text = read_toml_text(
        path,
        "config file",
        hint="aion build --print-config > model.toml writes a valid file to edit",
    )
    return ModelConfig.from_toml_text(text)


def series_of(
    t_from: str, t_to: str, step: str, tz: str | None, loaded: Any, noun: str = "times"
) -> tuple[list[int], Zone]:
    """The times of ``--from`` .. ``--to`` (inclusive) every ``--step``, in the zone
    :func:`resolve_time` reads them in, which is also the zone whose calendar days a step in
    days or weeks counts (``export`` and ``predict`` series)."""
    from aion_cli.prediction_series import series_times

    start, zone = resolve_time(t_from, tz, loaded, option="--from")
    end, _ = resolve_time(t_to, tz, loaded, after_ns=start, option="--to")
    return series_times(start, end, parse_step(step), zone, noun=noun, typed=t_from), zone


def parse_span(text: str, zone: Zone, option: str, instant: bool = False) -> tuple[int, int]:
    """``START..END`` -> ``(start_ns, end_ns)`` for ``option`` (``--observed``, ``--leave``):
    each side is any form ``aion_cli.timeparse`` reads (ISO with or without zone, UNIX
    seconds, ...), in ``zone`` unless it names one; an end that is a clock alone, a day word
    or relative counts from the start (``"2026-11-23 08:00..10:00"`` is two hours, not a
    span to today's 10:00; ``"08:00..+2h"`` ends at 10:00); the end must be after the
    start, or with ``instant`` (``--leave``, one departure as ``predict --from T --to T`` is
    one time) the start itself, unless two different wall-clock times fell on one instant."""
    from aion_cli.errors import InputError
    from aion_cli.timeparse import FORMS_HINT, TimeFormatError

    parts = text.split("..")
    if len(parts) != 2 or not all(p.strip() for p in parts):
        raise InputError(
            f"{option} {text!r}: expected START..END",
            hint=f'e.g. {option} "2017-06-09 09:00..2017-06-09 18:30" (times: {FORMS_HINT})',
        )
    try:
        start = parse_time(parts[0], zone)
        end = parse_time(parts[1], zone, start=_reference(start, zone))
    except TimeFormatError as exc:
        raise InputError(f"{option} {text!r}: {exc.message}", hint=exc.hint) from exc
    if end <= start:
        from aion_cli.engine.time_text import format_ns
        from aion_cli.timeparse import offset_changes_near, one_wall_clock, zone_named_in

        read = f" (read as {format_ns(start, zone)} .. {format_ns(end, zone)}"
        # two wall-clock times of one zone, one instant, where that zone changes its clock
        # (not "08:00..08:00", nor a UNIX time and its ISO form, nor "03:00..03:00" beside
        # Berlin's spring change, nor "03:30..01:30 UTC" read in Berlin's summer time)
        zones = [zone_named_in(p, zone) for p in parts]
        changed = (
            end == start
            and parts[0].strip() != parts[1].strip()
            and zones[0].tz == zones[1].tz
            and offset_changes_near(start, zones[0])
            and not one_wall_clock(parts[0], parts[1], zone)
        )
        read += ": a clock change skips or repeats an hour there)" if changed else ")"
        if instant and end == start and not changed:
            return start, end
        empty = end == start and not changed  # one time: a point, which observes nothing
        raise InputError(
            f"{option} {text!r}: the end is not after the start{read}",
            hint="give the span as START..END with END later than START"
            + (" (or the same time, for one departure)" if instant else "")
            + (f": {option} takes a span of time, and T..T is one instant (only --leave "
               "takes it, as the one departure T)" if empty and not instant else ""),
        )  # fmt: skip
    return start, end


def span_start_notes(texts: Sequence[str], spans: Sequence[tuple[int, int]], zone: Zone,
                     option: str) -> list[str]:
    """A note per ``START..END`` of ``option`` (``--observed``, ``--leave``; ``spans``: as
    :func:`parse_span` read them in ``zone``) whose start is a wall-clock time that a clock
    change skips or repeats, naming the instant it was read as
    (:func:`aion_cli.wall_clock.clock_change_note`), as ``--time`` and ``--from`` say it."""
    from aion_cli.wall_clock import clock_change_note

    notes = []
    for text, (start, _end) in zip(texts, spans, strict=True):
        changed = clock_change_note(text.split("..")[0], zone, start)
        if changed is not None:
            notes.append(f"{option} {changed}")
    return notes


def _frame_name(value: str | None, option: str, example: str) -> str | None:
    """A TF frame name as given (None: not given); an empty one is an error (an unset shell
    variable would otherwise make a robot's log a fixed sensor without a word), and so is one
    of slashes only (``/``: frames are compared without their leading slash, so it names no
    frame)."""
    if value is not None and not value.strip().lstrip("/"):
        raise click.BadParameter(f"a frame name, e.g. {example}", param_hint=option)
    return value


def map_frame_option(help_text: str) -> Callable[[F], F]:
    """``--map-frame FRAME`` (default None: the command's own), refusing an empty name."""
    return click.option(
        "--map-frame",
        metavar="FRAME",
        default=None,
        callback=lambda _ctx, _param, value: _frame_name(value, "--map-frame", "map"),
        help=help_text,
    )


def base_frame_option(func: F) -> F:
    """``--base-frame FRAME``: the robot frame of the TF trajectory (what the sensor saw)."""
    return click.option(
        "--base-frame",
        metavar="FRAME",
        default="base_link",
        show_default=True,
        callback=lambda _ctx, _param, value: _frame_name(value, "--base-frame", "base_link"),
        help="Robot frame whose TF trajectory gives what the sensor observed.",
    )(func)


def log_format_option(func: F) -> F:
    """``--log-format``: the container, where its path does not say (build, info, holdout)."""
    return click.option(
        "--log-format",
        type=click.Choice(["mcap", "bag", "rosbag2"], case_sensitive=False),
        help="Container format [default: guessed from the path].",
    )(func)


def _one_mapping(_ctx: click.Context, _param: click.Parameter, value: tuple[Path, ...]) -> Any:
    """The one mapping file given (None without): click would keep only the last of several,
    and the topics of the others would silently go unread."""
    files = list(dict.fromkeys(value))
    if len(files) > 1:
        raise click.BadParameter(
            f"given {len(files)} files ({', '.join(str(f) for f in files)}), but aion reads "
            "one: put all their [[topic]] tables into one file"
        )
    return files[0] if files else None


def detections_mapping_option(func: F) -> F:
    """``--detections-mapping FILE``: a TOML mapping of other message types to people."""
    return click.option(
        "--detections-mapping",
        "detections_mapping",
        type=AionPath(path_type=Path, dir_okay=False),
        multiple=True,
        callback=_one_mapping,
        metavar="FILE",
        help="TOML mapping that reads people from other message types (README, People "
        "detections; `aion info LOG --suggest-mapping TOPIC` writes one).",
    )(func)


def graph_topic_option(func: F) -> F:
    """``--graph-topic TOPIC``: the scene-graph topic, where finding it by type will not do."""
    return click.option(
        "--graph-topic",
        metavar="TOPIC",
        help="Scene-graph (hydra_msgs/DsgUpdate) topic [default: found by type].",
    )(func)
