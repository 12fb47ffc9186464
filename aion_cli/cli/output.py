"""Render rows of results as a rich table, JSON or CSV on stdout.

Field names are stable (documented in each command's ``--help``); JSON has ``null`` where a
value is unknown (NaN), CSV leaves the cell empty and flattens list fields into
``name_0 .. name_{k-1}`` columns.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import click

from aion_cli.cli.common import AionPath
from aion_cli.formats.serialize import to_csv, to_json

FORMATS = ("table", "json", "csv")

# C0 controls (ESC, BEL, CR, backspace...), DEL, C1 controls (CSI 0x9b...), and the Unicode
# line/paragraph separators and bidirectional overrides that reorder what a terminal shows.
_UNSAFE = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028-\u202e\u2066-\u2069]")
_NAMED = {"\t": "\\t", "\n": "\\n", "\r": "\\r"}


def _escape_char(match: re.Match[str]) -> str:
    char = match.group()
    named = _NAMED.get(char)
    if named is not None:
        return named
    code = ord(char)
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def printable(value: object) -> str:
    """``str(value)`` safe to print on a terminal: every control character (ESC and so every
    escape sequence, BEL, CR, backspace, C1 controls) and every bidirectional override becomes a
    visible escape (``\\x1b``, ``\\n``, ``\\u202e``); everything else, non-ASCII text included,
    is kept. Use it for any string that comes from a log or a map (topic names, frame ids,
    node labels, file contents) before it reaches the terminal."""
    text = value if isinstance(value, str) else str(value)
    return _UNSAFE.sub(_escape_char, text)


def markup_safe(value: object) -> str:
    """:func:`printable`, with rich markup escaped too (``[red]`` shown, not applied), for
    strings interpolated into text that ``console().print`` renders as markup."""
    from rich.markup import escape

    return escape(printable(value))


class AnyCase(click.Choice):
    """Choices taken in any case and named as listed: click 8.2 on shows a case-insensitive
    choice casefolded in ``--help`` and in its error (``geometry_msgs/msg/posearray``, a
    type no log holds), where the words have a case of their own."""

    def __init__(self, choices: Sequence[str]) -> None:
        super().__init__(list(choices), case_sensitive=False)

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "[" + "|".join(map(str, self.choices)) + "]"

    def get_invalid_choice_message(self, value: Any, ctx: click.Context | None) -> str:
        listed = ", ".join(repr(str(choice)) for choice in self.choices)
        return f"{value!r} is not one of {listed}."


def format_option(choices: Sequence[str] = FORMATS, default: str = "table") -> Any:
    """The ``--format`` option shared by the query commands."""
    machine = " or ".join(c.upper() for c in choices if c != "table")
    return click.option(
        "--format",
        "fmt",
        type=click.Choice(list(choices), case_sensitive=False),
        default=default,
        show_default=True,
        help=f"A table for people, or {machine} on stdout for scripts.",
    )


def map_output_option(what: str = "Map file") -> Any:
    """``-o/--output``, required, for the commands that write a map (``merge``, ``compact``):
    a new file, or an existing map to replace (the writer refuses anything else)."""
    from pathlib import Path

    return click.option(
        "-o",
        "--output",
        required=True,
        type=AionPath(path_type=Path, dir_okay=False),
        help=f"{what} to write (a new file, or an existing map to replace).",
    )


class AionCommand(click.Command):
    """A click command whose rarely used options get their own "Advanced options" section
    in ``--help`` (``advanced=`` names them by parameter name), and whose options that take
    one time (``once=``: parameter name -> hint) are refused when given twice: click keeps the
    last, and ``--time 08:00 --time 12:00`` answered for 12:00 alone without a word."""

    def __init__(
        self,
        *args: Any,
        advanced: Sequence[str] = (),
        once: dict[str, str] | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(*args, **kwargs)
        self.advanced = frozenset(advanced)
        self.once = dict(once or {})

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if self.once and not ctx.resilient_parsing:  # not while completing a command line
            try:
                _, _, order = self.make_parser(ctx).parse_args(args=list(args))
            except click.UsageError:
                order = []  # the parse below reports it
            for param in order:
                if param.name in self.once and order.count(param) > 1:
                    name = max(param.opts, key=len)
                    raise click.UsageError(
                        f"{name} was given {order.count(param)} times, but it takes one value "
                        f"(only the last would be used); {self.once[param.name]}",
                        ctx,
                    )
        return super().parse_args(ctx, args)

    def format_options(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        basic: list[tuple[str, str]] = []
        extra: list[tuple[str, str]] = []
        for param in self.get_params(ctx):
            if not isinstance(param, click.Option):
                continue  # arguments are in the usage line and the description
            record = param.get_help_record(ctx)
            if record is not None:
                (extra if param.name in self.advanced else basic).append(record)
        if basic:
            with formatter.section("Options"):
                formatter.write_dl(basic)
        if extra:
            with formatter.section("Advanced options"):
                formatter.write_dl(extra)


@dataclass(frozen=True)
class Column:
    """One output field: its key in the row dicts, table header and table cell formatter."""

    key: str
    header: str
    fmt: Callable[[Any], str] = str
    justify: str = "right"


def num(digits: int = 2) -> Callable[[Any], str]:
    """Table formatter for a float with ``digits`` decimals; '-' when unknown."""

    def render(value: Any) -> str:
        if value is None or (isinstance(value, float) and not math.isfinite(value)):
            return "-"
        from aion_cli.number_text import fixed

        return fixed(value, digits)

    return render


def small_num(value: Any) -> str:
    """Table formatter for a non-negative rate: two decimals, or two significant digits below
    0.1, so a small value reads 0.0017 or 1.2e-05, never 0.00 (which then means none); '-'
    when unknown."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    v = float(value)
    if v == 0 or abs(v) >= 0.1:
        return f"{v:.2f}"
    return f"{v:.2g}" if abs(v) >= 1e-4 else f"{v:.1e}"


def degrees(value: Any) -> str:
    """Table formatter for an angle in radians shown in whole degrees; '-' when unknown.
    A direction just below 0 reads +0° (not -0°), and -180° reads +180°: one direction, one
    label."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    whole = round(math.degrees(float(value)))
    return f"{180 if whole == -180 else whole:+d}°"


def render_table(
    rows: Sequence[dict[str, Any]], columns: Sequence[Column], title: str | None = None
) -> None:
    """A rich table on stdout. Every cell, header and the title are plain text made
    :func:`printable` (no markup is interpreted, no control character reaches the terminal)."""
    from rich.table import Table
    from rich.text import Text

    from aion_cli.cli.console import print_table

    table = Table(
        title=None if title is None else Text(printable(title)),
        show_lines=False,
        header_style="bold",
    )
    for col in columns:
        # a cell is one value (an id, a number, a histogram whose blanks are empty bins):
        # never wrapped, so a narrow terminal cannot fold a histogram into three lines
        table.add_column(
            Text(printable(col.header)), justify=col.justify, no_wrap=True  # type: ignore[arg-type]
        )
    for row in rows:
        table.add_row(*(Text(printable(col.fmt(row.get(col.key)))) for col in columns))
    print_table(table)


def emit(
    fmt: str,
    rows: Sequence[dict[str, Any]],
    columns: Sequence[Column],
    *,
    json_payload: Any | None = None,
    csv_keys: Sequence[str] | None = None,
    title: str | None = None,
) -> None:
    """Write ``rows`` on stdout in ``fmt`` ("table", "json" or "csv").

    ``json_payload`` replaces the plain row list as the JSON document (e.g. to add metadata);
    ``csv_keys`` chooses the CSV columns (default: every table column's key).
    """
    fmt = fmt.lower()
    if fmt == "json":
        click.echo(to_json(rows if json_payload is None else json_payload))
    elif fmt == "csv":
        click.echo(to_csv(rows, csv_keys or [c.key for c in columns]), nl=False)
    else:
        render_table(rows, columns, title)


def emit_chunks(chunks: Iterable[str], *, nl: bool) -> None:
    """Write text made in chunks on stdout (``aion_cli.entry_text``'s JSON and CSV), each
    as ``click.echo`` writes it, then a newline if ``nl``: the bytes one ``click.echo`` of
    the whole text writes (``echo`` strips ANSI sequences off-terminal; a chunk ends at a
    record's end, so no sequence spans two). A reader that stops early (``| head``) ends
    the command as every broken pipe does (``AionGroup.invoke``: exit 0, no message)."""
    for chunk in chunks:
        click.echo(chunk, nl=False)
    if nl:
        click.echo("")


def human_size(n: int) -> str:
    """Bytes as B / KiB / MiB / GiB."""
    value = float(n)
    for unit in ("B", "KiB", "MiB", "GiB"):
        if value < 1024 or unit == "GiB":
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1024
    return f"{n} B"  # pragma: no cover
