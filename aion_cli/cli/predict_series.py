"""``aion predict MAP --from T0 --to T1 [--step 1h]``: the predicted flow of places over a
series of times, as a table (one row per time, one column per entry), JSON or long CSV.

The numbers are :mod:`aion_cli.prediction_series`'s; this module checks the options and
formats them for people."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from aion_cli.engine.time_text import Zone

#: entries a terminal table shows as columns (JSON and CSV have every entry)
TABLE_COLUMNS = 8


def check_series_options(
    t_from: str | None,
    t_to: str | None,
    step: str | None,
    historical: bool,
    time_given: bool,
    tz_given: bool = False,
) -> bool:
    """Whether a series was asked for; an :class:`InputError` for options that contradict
    (``--historical`` has no time, so no ``--time``). A ``--tz`` beside ``--historical``
    changes nothing, but is harmless (a shell alias may always give one): a note says so,
    instead of taking it silently or refusing the command."""
    from aion_cli.errors import InputError

    if historical and time_given:
        raise InputError(
            "--historical is what was observed, at no time: it takes no --time",
            hint="leave out --time, or --historical",
        )
    if historical and tz_given:
        from aion_cli.cli.console import note

        note("--tz changes nothing with --historical: what was observed has no time of day")
    if t_from is None and t_to is None:
        if step is not None:
            raise InputError("--step needs --from and --to", hint="e.g. --from 08:00 --to 18:00")
        return False
    if t_from is None or t_to is None:
        raise InputError("a series needs both --from and --to", hint="e.g. --from 08:00 --to 18:00")
    if historical:
        raise InputError(
            "--historical is what was observed, at no time: it has no series",
            hint="leave out --from/--to, or --historical",
        )
    if time_given:
        raise InputError(
            "choose one of --time or --from/--to",
            hint="--time T: the forecast at T; --from/--to (--step): a series of forecasts",
        )
    return True


def run_series(
    map_path: Path,
    loaded: Any,
    t_from: str,
    t_to: str,
    step: str,
    tz: str | None,
    request: tuple[str, tuple[str, ...], str | None, int | None],
    fmt: str,
) -> None:
    """Predict at every time of the series and write it in ``fmt``; ``request`` is
    (layer, nodes, at, top)."""
    from aion_cli.cli.common import announce_time, series_of
    from aion_cli.cli.console import note, progress
    from aion_cli.cli.output import emit_chunks
    from aion_cli.engine.time_text import format_ns
    from aion_cli.entry_text import series_csv, series_json
    from aion_cli.prediction_series import SERIES_CSV_KEYS, described, predict_series
    from aion_cli.predictions import hour_flags

    times, zone = series_of(t_from, t_to, step, tz, loaded)
    layer, nodes, at, top = request
    # a table shows the busiest TABLE_COLUMNS: only theirs are kept (the same entries)
    keep = TABLE_COLUMNS if top is None and fmt not in ("json", "csv") else top
    with progress(quiet=len(times) == 1) as bar:
        task = bar.add_task("predicting", total=len(times), unit="times")
        table = predict_series(
            loaded, times, layer, nodes, at, keep, lambda done: bar.update(task, completed=done)
        )
    labels = [format_ns(t, zone) for t in times]
    announce_time(times[0], zone, "from", loaded, series=times, text=t_from)
    say_nearest(at, table.entries[0] if table.entries else None)
    say_flowless(loaded, [e["kind"] for e in table.entries] if table.columns is None
                 else table.columns.column("kind"))  # fmt: skip
    if fmt in ("json", "csv"):  # to_json(.to_dict()) / to_csv(.long_rows(labels), KEYS) text
        full = described(table, map_path, zone, labels, hour_flags(loaded, times))
        if fmt == "json":
            emit_chunks(series_json(full), nl=True)
        else:
            emit_chunks(series_csv(full, labels, SERIES_CSV_KEYS), nl=False)
    else:
        shown = len(table.entries) if top is not None else min(TABLE_COLUMNS, len(table.entries))
        if top is None and shown < table.matched:
            note(
                f"showing the {shown} busiest of {table.matched:,} entries over the series: use "
                "--node, --top N, --format csv or --format json for others"
            )
        _print(table, zone, shown, hour_flags(loaded, times))


def say_flowless(loaded: Any, kinds: Any) -> None:
    """A note when the rows (their ``kinds``) are places, rooms or buildings of a map whose
    places hold no detection (:func:`aion_cli.api_results.flowless_rows_note`)."""
    from aion_cli.api_results import flowless_rows_note
    from aion_cli.cli.console import note

    said = flowless_rows_note(loaded.state, kinds)
    if said is not None:
        note(said)


def say_nearest(at: str | None, entry: dict[str, Any] | None) -> None:
    """With ``--at``, a note naming the entry the point stands for and how far it is (the
    table showed an entry, possibly metres away, without a word that it was the nearest); a
    room or building is the one holding the place nearest the point (``entry_selection``)."""
    if at is None or entry is None:
        return
    from aion_cli.cli.console import note
    from aion_cli.engine.node_ids import point_distance, require_point

    kind = entry.get("kind")
    if kind in ("room", "building"):  # chosen by the place nearest the point, not its centre
        note(f"--at {at}: the point stands for {entry['id']}, the {kind} holding the place "
             "nearest it")
        return
    xyz = (float(entry["x"]), float(entry["y"]), float(entry["z"]))
    away = point_distance(xyz, require_point(at, "--at"))
    note(f"--at {at}: the entry nearest the point is {entry['id']}, {away:.2f} m from it")


def short_labels(times_ns: list[int], zone: Zone) -> list[str]:
    """Row labels for a terminal: ``08:30`` within one day, ``Mon 08:30`` within a week,
    else ``2026-11-23 08:30``."""
    from aion_cli.engine.time_text import clock_labels, from_ns

    stamps = [from_ns(t, zone) for t in times_ns]
    days = {s.date() for s in stamps}
    if len(days) == 1:
        form = "%H:%M"
    elif (max(days) - min(days)).days < 7:
        form = "%a %H:%M"
    else:
        form = "%Y-%m-%d %H:%M"
    if any(s.second for s in stamps):
        form += ":%S"
    return clock_labels(times_ns, zone, form)


def _print(table: Any, zone: Zone, shown: int, observed: list[bool | None]) -> None:
    """The series as a table, a time at an hour no log observed (``observed`` False) marked
    ``extrapolated`` (its forecast is each entry's static rate: the notes say so)."""
    from rich.table import Table
    from rich.text import Text

    from aion_cli.cli.console import print_table
    from aion_cli.cli.output import printable, small_num
    from aion_cli.engine.time_text import from_ns

    days = sorted({from_ns(t, zone).date().isoformat() for t in table.times_ns})
    when = days[0] if len(days) == 1 else f"{days[0]} .. {days[-1]}"
    title = printable(f"predicted flow per window, {when} ({zone.name})")
    out = Table(title=Text(title), min_width=len(title))  # a narrow table keeps its title whole
    out.add_column("time", style="bold", no_wrap=True)
    for entry in table.entries[:shown]:
        head = str(entry["id"]) if not entry.get("name") else f"{entry['name']} ({entry['id']})"
        out.add_column(printable(head), justify="right", no_wrap=True)
    labels = short_labels(table.times_ns, zone)
    for j, (clock, seen) in enumerate(zip(labels, observed, strict=True)):
        label = clock if seen is not False else f"{clock} extrapolated"
        cells = [
            small_num(v) if math.isfinite(v) else "–"  # 0.0031, not 0.00; unknown flow
            for v in table.flow[:shown, j].tolist()
        ]
        out.add_row(label, *cells)
    print_table(out)
