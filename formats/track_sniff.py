"""Which tracks layout a file looks like, from its first lines.

``aion convert`` reads a tracks file in the layout it is told (``--layout``, default
``canonical``): the public datasets share columns (ATC and THÖR are both ``time, id, x, y,
speed, angle``; Lincoln's heading CSV has six comma-separated numbers too), so a layout cannot
be chosen from content alone without sometimes reading a file wrongly. What content can do is
*say* what a file looks like:

- when the file does not fit the layout asked for (the canonical header is missing), the error
  names the layout it does look like, and why;
- when it fits the asked layout's columns but its content says another one (THÖR's times from
  0 read as ATC's UNIX seconds, which dates every detection 1970; Lincoln's id-less rows read
  as ATC, which makes one track of everything), the converter warns.

:func:`guess_layout` reads at most :data:`SNIFF_BYTES` of the file and never raises for what
it cannot place: it returns None.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from aion_cli.formats.track_csv import CANONICAL_HEADER

#: bytes read from the start of a file to guess its layout
SNIFF_BYTES = 65_536
#: data lines looked at
SNIFF_LINES = 50
#: the smallest first time read as UNIX seconds (1973-03-03): dataset clocks that count from
#: the recording's start stay far below it
UNIX_SECONDS_FROM = 1e8


@dataclass(frozen=True)
class LayoutGuess:
    """The layouts a file's first lines fit (equivalent ones together, e.g. eth and ucy) and
    what in the file says so."""

    layouts: tuple[str, ...]
    why: str

    @property
    def layout(self) -> str:
        return self.layouts[0]

    def describe(self) -> str:
        """``the thor layout (six comma-separated numbers, times from 0)``."""
        names = " or ".join(self.layouts)
        return f"the {names} layout ({self.why})"


def guess_layout(path: str | Path) -> LayoutGuess | None:
    """The layout ``path`` looks like, or None (unreadable, empty, or like no layout)."""
    try:
        with Path(path).open("rb") as fh:
            head = fh.read(SNIFF_BYTES)
    except OSError:
        return None
    text = head.decode("utf-8-sig", errors="replace")
    if "TRACK.R" in text or "Properties.R" in text:
        return LayoutGuess(("edinburgh",), "TRACK.Rn=[...] entries")
    lines = [line.strip() for line in text.splitlines()]
    if len(head) == SNIFF_BYTES and len(lines) > 1:
        lines = lines[:-1]  # the last line may be cut
    lines = [line for line in lines if line and not line.startswith("#")]
    if not lines:
        return None
    first = lines[0]
    if first.replace(" ", "") == CANONICAL_HEADER:
        return LayoutGuess(("canonical",), "its header " + CANONICAL_HEADER)
    names = [name.strip().strip('"') for name in first.split(",")]
    if "Time" in names and "ag_id" in names:
        return LayoutGuess(("thor-magni",), "a header with Time and ag_id")
    return _numeric_guess(lines[:SNIFF_LINES])


def _numbers(line: str, comma: bool) -> list[float] | None:
    fields = [f.strip() for f in line.split(",")] if comma else line.split()
    try:
        return [float(f) for f in fields]
    except ValueError:
        return None


def _numeric_guess(lines: list[str]) -> LayoutGuess | None:
    """Header-less tables of numbers: ATC, THÖR, ETH/UCY and Lincoln's variants."""
    comma = "," in lines[0]
    first = lines[0].split(",") if comma else lines[0].split()
    if not comma and len(first) == 6 and _numbers(" ".join(first[:5]), False) is not None:
        t = float(first[0])
        if t >= UNIX_SECONDS_FROM and _numbers(first[5], False) is None:
            return LayoutGuess(("lincoln",), "rows `t x y a b WPn` with UNIX seconds")
    rows = [_numbers(line, comma) for line in lines]
    if len(rows) > 1 and rows[0] is not None and len(rows[0]) == 2 and not comma:
        t0, t1 = rows[0]
        if t0 >= UNIX_SECONDS_FROM and t1 > t0:
            return LayoutGuess(("lincoln",), "a `t_start t_end` header line of UNIX seconds")
    parsed = [r for r in rows if r is not None and all(math.isfinite(v) for v in r)]
    if not parsed or len(parsed) < len(rows) // 2 + 1:
        return None
    width = len(parsed[0])
    if any(len(r) != width for r in parsed):
        return None
    unix = parsed[0][0] >= UNIX_SECONDS_FROM
    if comma and width == 6:
        if unix and all(r[1] == 0 for r in parsed) and all(r[4] == parsed[0][4] for r in parsed):
            return LayoutGuess(
                ("lincoln",), "rows `t, id, x, y, z, heading` with UNIX seconds and id always 0"
            )
        if unix:
            return LayoutGuess(("atc",), "six comma-separated numbers, UNIX seconds first")
        return LayoutGuess(("thor",), "six comma-separated numbers, times from 0 first")
    if not comma and width in (3, 4) and unix:
        return LayoutGuess(("lincoln",), f"rows of {width} numbers with UNIX seconds first")
    if not comma and width == 4 and all(r[0].is_integer() and r[1].is_integer() for r in parsed):
        return LayoutGuess(("eth", "ucy"), "rows `frame ped_id x y`")
    return None


def other_layout_hint(path: str | Path, layout: str) -> str | None:
    """``it looks like the thor layout (...): pass --layout thor`` when ``path``, refused as
    ``layout``, looks like another layout; else None (the refusal keeps its own hint)."""
    guess = guess_layout(path)
    if guess is None or layout in guess.layouts:
        return None
    return f"it looks like {guess.describe()}: pass --layout {guess.layout}"


def layout_mismatch(path: str | Path, layout: str) -> str | None:
    """A warning when ``path`` was read as ``layout`` but looks like another layout; None
    when it fits. (``convert --start`` with a clock of the other kind is refused before:
    ``cli.convert_checks.check_start_applies``.)"""
    guess = guess_layout(path)
    if guess is None or layout in guess.layouts:
        return None
    return (
        f"{Path(path).name} was read as the {layout} layout but looks like "
        f"{guess.describe()}: convert it with --layout {guess.layout} if that is what it is"
    )

