"""``aion plan --leave START..END [--step 10m]``: when to leave. The same plan at every
departure of the span (``routes.plan_departures``), the best one (least temporal cost) shown
as ``aion plan --time`` shows a plan, after a table of every departure's cost."""

from __future__ import annotations

from typing import Any

from aion_cli.engine.time_text import Zone

#: departures a terminal table lists (JSON has every one)
TABLE_ROWS = 48


def departure_times(text: str, step: str, zone: Zone) -> list[int]:
    """The departures of ``--leave START..END`` every ``--step`` (END included when it falls
    on a step; ``T..T`` is the one departure T; a step in days or weeks counts calendar days
    in ``zone``; at most 1,000)."""
    from aion_cli.cli.common import parse_span
    from aion_cli.prediction_series import series_times
    from aion_cli.time_steps import parse_step

    start, end = parse_span(text, zone, "--leave", instant=True)  # "T..T": one departure
    typed = text.split("..")[0]  # a daily series keeps its wall-clock time
    return series_times(start, end, parse_step(step), zone, noun="departures", typed=typed)


def print_departures(rows: list[dict[str, Any]], zone: Zone) -> None:
    """The departures as a table (stdout), the best one marked, and those at an hour no day
    observed (their flows extrapolated)."""
    from rich.table import Table
    from rich.text import Text

    from aion_cli.cli.console import note, print_table
    from aion_cli.cli.predict_series import short_labels

    best = next(k for k, row in enumerate(rows) if row["best"])
    shown = list(range(len(rows)))
    if len(rows) > TABLE_ROWS:  # around the best one
        first = min(max(0, best - TABLE_ROWS // 2), len(rows) - TABLE_ROWS)
        shown = shown[first : first + TABLE_ROWS]
        note(f"showing {TABLE_ROWS} of {len(rows)} departures around the best: --format json "
             "lists every one")
    from aion_cli.engine.time_text import from_ns

    labels = short_labels([row["depart_ns"] for row in rows], zone)
    # the day(s) and zone of the times, as predict's series names them: the leave column
    # holds clock times only, and stdout kept in a file has no stderr note beside it
    days = sorted({from_ns(row["depart_ns"], zone).date().isoformat() for row in rows})
    when = days[0] if len(days) == 1 else f"{days[0]} .. {days[-1]}"
    title = f"departures, {when} ({zone.name}): temporal cost, lower is quieter"
    table = Table(title=Text(title), min_width=len(title))  # plain text, no markup
    for name in ("leave", "cost", "length", "time", ""):
        table.add_column(name, justify="left" if name in ("leave", "") else "right", no_wrap=True)
    for k in shown:
        row = rows[k]
        table.add_row(
            labels[k],
            f"{row['cost']:.1f}",
            f"{row['length_m']:.1f} m",
            f"{row['duration_s']:.0f} s",
            ", ".join(
                (["best"] if row["best"] else [])
                + (["extrapolated"] if row.get("hour_observed") is False else [])
            ),
            style="bold green" if row["best"] else None,
        )
    print_table(table)
