"""The scene's clock: local wall-clock time (what people's routines and the patrol hours
follow) against elapsed time since the scene started (what the simulation's ticks count).

With a fixed offset from UTC (``--utc-offset``) the two differ by a constant. With a zone that
keeps daylight saving (``--tz Europe/London``) they do not: on the day the clocks go forward
people still arrive at 09:00 on the wall, an hour earlier in UTC than the day before, and the
day has 23 hours of ticks. :meth:`SceneClock.elapsed` maps wall times to elapsed seconds by
the zone's own rules (looked up once per distinct wall hour); a wall time in the hour the
clocks skip is taken at the first instant after it, so the mapping never runs backwards, and
in the hour they repeat it means the first of the two.
"""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.temporal.calendar import Calendar
from aion_cli.engine.temporal.zones import zone_of

F64 = npt.NDArray[np.float64]
_HOUR_S = 3600.0


@dataclass(frozen=True)
class SceneClock:
    """The local clock of a scene starting on ``day`` at ``offset_s`` seconds after local
    midnight, in ``timezone`` (a zone name or fixed offset, as ``--tz`` takes) or, without
    one, ``utc_offset_h`` hours ahead of UTC."""

    day: _dt.date
    offset_s: float
    utc_offset_h: float = 0.0
    timezone: str | None = None

    def _tz(self) -> _dt.tzinfo:
        if self.timezone is None:
            return _dt.timezone(_dt.timedelta(hours=self.utc_offset_h))
        return zone_of(self.timezone)

    def _midnight_utc_s(self) -> float:
        """UNIX seconds of local midnight of ``day`` read as if its offset held all day."""
        naive = _dt.datetime(self.day.year, self.day.month, self.day.day, tzinfo=_dt.UTC)
        return naive.timestamp()

    def wall_to_unix_s(self, wall_s: npt.ArrayLike) -> F64:
        """UNIX seconds of wall times given as seconds after local midnight of ``day``
        (any number of days on), never decreasing where the wall times do not."""
        wall = np.asarray(wall_s, dtype=np.float64).reshape(-1)
        base = self._midnight_utc_s()
        if self.timezone is None:  # a fixed offset: the constant shift, exactly as before
            out: F64 = base + wall - self.utc_offset_h * _HOUR_S
            return out
        tz = self._tz()
        hours, inverse = np.unique(np.floor(wall / _HOUR_S), return_inverse=True)
        start = _dt.datetime(self.day.year, self.day.month, self.day.day)
        offsets = np.array(
            [
                (
                    (start + _dt.timedelta(hours=float(h))).replace(tzinfo=tz).utcoffset()
                    or _dt.timedelta(0)
                ).total_seconds()
                for h in hours.tolist()
            ]
        )
        unix = base + wall - offsets[inverse.reshape(-1)]
        order = np.argsort(wall, kind="stable")
        unix[order] = np.maximum.accumulate(unix[order])  # the skipped hour runs forward
        return unix

    def start_unix_s(self) -> float:
        """UNIX seconds of the scene's start."""
        return float(self.wall_to_unix_s([self.offset_s])[0])

    def start_ns(self) -> int:
        """UNIX ns of the scene's start: in integers for a fixed offset (exact), else through
        the zone's rules."""
        if self.timezone is not None:
            return round(self.start_unix_s() * 1e9)
        midnight = int(self._midnight_utc_s()) * 1_000_000_000
        return midnight + round(self.offset_s * 1e9) - round(self.utc_offset_h * 3600e9)

    def elapsed(self, wall_s: npt.ArrayLike) -> F64:
        """Seconds since the scene's start of wall times (seconds after local midnight of
        ``day``)."""
        wall = np.asarray(wall_s, dtype=np.float64).reshape(-1)
        if self.timezone is None:  # as the fixed-offset simulation always computed it
            fixed: F64 = wall - self.offset_s
            return fixed
        out: F64 = self.wall_to_unix_s(wall) - self.start_unix_s()
        return out

    def wall(self, elapsed_s: npt.ArrayLike) -> F64:
        """Seconds after local midnight of ``day`` of elapsed times (the inverse of
        :meth:`elapsed` outside the hours the clocks skip or repeat)."""
        t = np.asarray(elapsed_s, dtype=np.float64).reshape(-1)
        if self.timezone is None:
            fixed: F64 = t + self.offset_s
            return fixed
        unix_ns = np.round((self.start_unix_s() + t) * 1e9).astype(np.int64)
        local_s = Calendar(self.timezone).local_ns(unix_ns) / 1e9  # the maps' UTC -> local
        out: F64 = local_s - self._midnight_utc_s()
        return out
