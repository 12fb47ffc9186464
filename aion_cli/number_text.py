"""Numbers as text for people: table cells, report pages, one-line summaries (no click or rich
here, so the command line's tables, the HTML report and the evaluation's markdown share it).

A value that rounds to zero reads ``0.00``, never ``-0.00`` (a tiny negative correlation, a
direction of -6e-16 degrees); a spread of exactly zero (one scene, identical runs) is left
out rather than printed as ``± 0.00``.
"""

from __future__ import annotations

import math
from typing import Any

WINDOWS_OBSERVED = "observed windows (most of any entry)"
"""The label of ``state_counts``' ``windows`` in the build, merge and report tables: the most
windows any one place or cell was observed, each window for the share of it recorded (a log
from 08:05 to 08:50 observed 4.5 windows of 10 min, shown rounded half up: 5), not the
windows with messages ``aion info`` counts for a log (every window touched)."""


def counted(n: int, noun: str) -> str:
    """``n`` and ``noun``, plural unless one: ``"1 log"``, ``"1,204 windows"``."""
    return f"{n:,} {noun}{'' if n == 1 else 's'}"


def half_up(value: float) -> int:
    """``value`` rounded to the nearest whole number, a half up (4.5 reads 5, as people
    round; Python's ``round`` takes a half to the even number: 4.5 to 4, 5.5 to 6)."""
    return math.floor(value + 0.5)


def fixed(value: float, digits: int, *, sign: bool = False) -> str:
    """``value`` with ``digits`` decimals (``sign``: with its sign, ``+`` included), never a
    negative zero: -0.0004 at two digits reads ``0.00`` (``+0.00`` with ``sign``)."""
    text = f"{float(value):{'+' if sign else ''}.{digits}f}"
    if text.startswith("-") and not text.strip("-0."):
        return ("+" if sign else "") + text[1:]
    return text


def significant(value: float, digits: int = 3) -> str:
    """``value`` to ``digits`` significant digits, without an exponent, thousands separated:
    ``0.974``, ``46.8``, ``10``, ``1,570`` (``:.3g`` wrote 1,570 detections a window as
    ``1.57e+03``); a value that is 0 or not finite as ``:g`` writes it."""
    v = float(value)
    if v == 0 or not math.isfinite(v):
        return f"{v:g}"
    places = digits - 1 - math.floor(math.log10(abs(v)))
    v = round(v, places)
    text = f"{v:,.{max(places, 0)}f}"
    if "." in text:  # trailing zeros left out, as :g leaves them: 10.0 reads 10
        text = text.rstrip("0").rstrip(".")
    return text


def mean_spread(value: Any, digits: int = 2) -> str:
    """A ``(mean, spread)`` pair as ``0.25 ± 0.03``; the mean alone for a spread of exactly
    zero; ``--`` for None (no value)."""
    if value is None:
        return "--"
    mean, spread = value
    if spread == 0:
        return fixed(mean, digits)
    return f"{fixed(mean, digits)} ± {fixed(spread, digits)}"


#: spans of this many seconds or more read in days and hours (``2d00h``), not ``48h00m00s``
DAYS_FROM_S = 2 * 86400


def span_text(seconds: float | None) -> str:
    """``5m07s``, ``47h59m59s``; a span under a minute in seconds (``0.3 s``: a 0.3 s log
    read ``0m00s``); two days or more in days and hours, to the nearest hour, thousands
    separated (``5d00h``; a log stamped mostly in 1970 and once in 2026 spans
    ``20,454d00h``, where it read ``490896h00m00s``)."""
    if seconds is None:
        return "-"
    if seconds < 59.5:
        return f"{seconds:.1f} s"
    whole = round(seconds)
    if whole >= DAYS_FROM_S:
        days, hours = divmod((whole + 1800) // 3600, 24)
        return f"{days:,}d{hours:02d}h"
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}h{minutes:02d}m{secs:02d}s" if hours else f"{minutes}m{secs:02d}s"
