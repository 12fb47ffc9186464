"""Series steps: ``--step`` (and the API's ``step``) read as calendar days plus elapsed time,
and the times of a series from its start. Apart from :mod:`aion_cli.timeparse`, which reads
single times and zones: a step is a length, not a moment."""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timedelta
from decimal import Decimal

from aion_cli.engine.time_text import Zone, from_ns
from aion_cli.timeparse import (
    MAX_TIME_NS,
    MIN_TIME_NS,
    NS_PER_S,
    RANGE_TEXT,
    RE_REL_PART,
    UNITS_S,
    TimeFormatError,
    refuse_capital_m,
    to_ns,
)


@dataclass(frozen=True)
class Step:
    """A series step: ``days`` whole calendar days in the series' zone, then ``exact_ns`` of
    elapsed time. ``--step`` written in days or weeks (``1d``, ``2d``, ``1w``) is calendar days,
    so a daily series keeps its wall-clock time across a daylight-saving change (12:00 every
    day, 23 or 25 hours apart on the change); hours, minutes and seconds (``24h``, ``90m``,
    ``600``) are exact elapsed time, so ``24h`` from 12:00 reads 13:00 after the spring change.
    A day's fraction is elapsed time (``1.5d`` is one calendar day and 12 hours)."""

    days: int
    exact_ns: int

    @property
    def nominal_ns(self) -> int:
        """The step's length taking every day as 24 h (the length of most steps)."""
        return self.days * 86400 * NS_PER_S + self.exact_ns


_STEP_HINT = "e.g. --step 1h, 30m, 600s or 1d"


def parse_step(step: str | float, option: str = "--step") -> Step:
    """A series step: text (``"1h"``, ``"30m"``, ``"600s"``, ``"1h30m"``, ``"1d"``, ``"1w"``, or
    ``"600"`` seconds) or seconds as a number (elapsed time), at least 1 s and at most the time
    range aion handles; :class:`TimeFormatError` otherwise, naming ``option`` as the user gave
    it (``--step`` on the command line, ``step`` in the API, whose hint gives its form). Each
    unit at most once (``1h30m``, not ``1h1h``)."""
    days = Decimal(0)
    seconds = Decimal(0)
    api = not option.startswith("--")
    name = option if isinstance(step, str) or api else "step"
    hint = "e.g. step='1h', '30m', '600s', '1d' or 600 (seconds)" if api else _STEP_HINT
    if isinstance(step, str):
        refuse_capital_m(step, name)
        token = step.strip().lower()
        if token.startswith("-"):  # a length has no sign; "-1h" read as unreadable text
            raise TimeFormatError(
                f"{name} {step!r} has a minus sign: a step is a length, and a series runs "
                "forward from its start",
                hint,
            )
        token = token.removeprefix("+").lstrip()
        if token.replace(".", "", 1).isdigit():
            seconds = Decimal(token)
        else:
            parts = RE_REL_PART.findall(token)
            if not parts or "".join(a + u for a, u in parts) != token.replace(" ", ""):
                raise TimeFormatError(f"cannot read the step {step!r}", hint)
            units = [UNITS_S.get(unit, unit) for _, unit in parts]  # "m" and "min" alike
            if len(set(units)) < len(units):  # "1h1h" had been read as 2h: surely a slip
                twice = next(p[1] for p, s in zip(parts, units, strict=True) if units.count(s) > 1)
                raise TimeFormatError(f"{name} {step!r} gives the unit {twice!r} twice", hint)
            for amount, unit in parts:
                if unit not in UNITS_S:
                    raise TimeFormatError(f"unknown unit {unit!r} in {name} {step!r}", "w d h m s")
                if unit in ("w", "d"):
                    days += Decimal(amount) * (UNITS_S[unit] // 86400)
                else:
                    seconds += Decimal(amount) * UNITS_S[unit]
    else:
        value = float(step)
        if not math.isfinite(value):
            raise TimeFormatError(f"step must be finite, got {step!r}", hint)
        seconds = Decimal(value)
    whole = int(days)  # never negative: the text has no sign
    seconds += (days - whole) * 86400
    total = whole * 86400 + seconds
    if not total >= 1:  # frames are named by the second (and a 0 s step never ends)
        raise TimeFormatError(f"{name} must be at least 1 s, got {step!r}", hint)
    if not total <= Decimal(MAX_TIME_NS - MIN_TIME_NS) / NS_PER_S:
        raise TimeFormatError(
            f"{name} {step!r} is longer than the time range aion handles ({RANGE_TEXT})",
            hint,
        )
    return Step(whole, int(seconds * NS_PER_S))


def step_time(
    start_ns: int, step: Step, k: int, zone: Zone, wall: datetime | None = None
) -> int:
    """The ``k``-th time of a series from ``start_ns`` every ``step``: ``k * step.days``
    calendar days after the start at the start's wall-clock time in ``zone``, then ``k *
    step.exact_ns`` later. Each time is counted from the start, so no error accumulates. A
    wall-clock time a daylight-saving change skips or repeats is read as ``--time`` reads it
    (PEP 495's ``fold=0``): a skipped one (02:30 on the spring change in Europe/Berlin) is
    taken with the offset before the change, so it falls as much later as the clocks jump
    (03:30 summer time); a repeated one (02:30 on the autumn change) is its first occurrence
    (summer time). ``wall``: the wall-clock time (naive) the start was typed as where the
    change skipped it (:func:`aion_cli.wall_clock.skipped_wall`), which the other days keep
    (02:30 again, not the 03:30 the start was read as)."""
    if step.days == 0 or k == 0:
        return start_ns + k * step.exact_ns
    start = from_ns(start_ns, zone)
    below_us = start_ns - to_ns(start)  # the nanoseconds a datetime cannot hold
    day = (start.replace(tzinfo=None) if wall is None else wall) + timedelta(days=k * step.days)
    return to_ns(day.replace(tzinfo=zone.tz, fold=0)) + below_us + k * step.exact_ns
