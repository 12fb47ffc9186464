"""Options and helpers shared by the commands that read a map (predict, plan, export)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from aion_cli.cli.timeparse import Zone, format_ns, parse_time, resolve_zone

F = TypeVar("F", bound=Callable[..., Any])

TIME_HELP = (
    'When: "2026-11-23 08:30", "2026-11-23T08:30:00+01:00", UNIX seconds, "now", "+2h", '
    '"-30m", "tomorrow 12:00", "monday 08:30".'
)


def map_argument(func: F) -> F:
    """The MAP positional argument (existence is checked by ``load_map`` with a clear error)."""
    return click.argument("map_path", metavar="MAP", type=click.Path(path_type=Path))(func)


def tz_option(func: F) -> F:
    """``--tz``: the zone for times without an offset."""
    return click.option(
        "--tz",
        metavar="ZONE",
        help="Time zone for times without an offset: IANA name, UTC, +01:00 "
        "[default: the machine's local zone].",
    )(func)


def resolve_time(text: str, tz: str | None, *, quiet: bool = False) -> tuple[int, Zone]:
    """Parse ``text`` in zone ``tz``; say on stderr which time and zone were used."""
    zone = resolve_zone(tz)
    t_ns = parse_time(text, zone)
    if not quiet:
        from aion_cli.cli.console import note

        note(f"time: {format_ns(t_ns, zone)} ({zone.name})")
    return t_ns, zone


def load(map_path: Path) -> Any:
    """Read a map (``aion_cli.pipeline.load_map``)."""
    from aion_cli.pipeline import load_map

    return load_map(map_path)
