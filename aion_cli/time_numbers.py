"""Bare numbers typed as a time (``--time``, ``--from``, a span's ends) that UNIX seconds
would misread: they are refused with the forms meant, where :mod:`aion_cli.timeparse` would
have read a time in 1969 or 1970 without a word. ``@`` before the number (``@20261123``,
``@-5``) says UNIX seconds and is read as such.
"""

from __future__ import annotations

import re
from datetime import date


def refuse_misread_number(text: str) -> None:
    """:class:`~aion_cli.timeparse.TimeFormatError` for ``text``, a number without ``@`` or a
    unit, when it is

    * eight digits that are a date in ISO 8601's basic form (``20261123``): read as UNIX
      seconds they were a time in 1970, while ``20261123T0830`` is read as the date it is;
    * negative (``-5``): read as UNIX seconds it was 1969-12-31 23:59:55 UTC, where a time
      before now (``-5h``, as ``-30m`` is) lacked its unit.
    """
    from aion_cli.engine.time_text import format_ns
    from aion_cli.timeparse import NS_PER_S, TimeFormatError, resolve_zone

    utc = resolve_zone("UTC")
    seconds = float(text)
    if seconds < 0:
        raise TimeFormatError(
            f"{text!r} reads as UNIX seconds before 1970 "
            f"({format_ns(round(seconds * NS_PER_S), utc)}): a time before now needs a unit",
            f'write "{text}h", "{text}m" or "{text}s" for a time before now, "@{text}" for '
            "UNIX seconds before 1970",
        )
    if not re.fullmatch(r"(19|2[0-2])\d{2}(0[1-9]|1[0-2])(0[1-9]|[12]\d|3[01])", text):
        return
    try:
        day = date(int(text[:4]), int(text[4:6]), int(text[6:]))
    except ValueError:  # 20260231: no date, UNIX seconds after all
        return
    raise TimeFormatError(
        f"{text!r} is the date {day.isoformat()} in ISO 8601's basic form, or "
        f"{format_ns(int(text) * NS_PER_S, utc)} as UNIX seconds",
        f'write "{day.isoformat()}" for the date, "@{text}" for UNIX seconds',
    )
