"""Local calendar time of window times: the day a window belongs to and its profile bin.

People's routines follow the local clock, so the periodic profile (hour of day × weekday /
weekend, or hour of week) and the day-ahead scoring days are taken in the map's time zone
(``ModelConfig.timezone``: ``UTC``, a fixed offset such as ``UTC+09:00``, or an IANA name such
as ``Europe/London``, daylight saving included). The zone is a model parameter, stored with the
map, so a map gives the same profile wherever it is read.

Profiles (``ModelConfig.profile``), with bins of ``profile_bin_s`` seconds (an hour by default):

* ``day``: H = 24 bins, the hour of the day;
* ``day_weekend``: H = 48, the hour of the day on weekdays (bins 0..23) and on Saturdays and
  Sundays (bins 24..47) — the default;
* ``week``: H = 168, the hour of the week, Monday 00:00 first.

Local days are counted from 1970-01-01 in local time (``day(t)``); weekday 0 is Monday. Offsets
are looked up once per distinct UTC quarter hour of the input (zone rules change on a quarter
hour: St John's and Adelaide change at a UTC half hour, which a lookup per UTC hour took half an
hour late; a change at another minute would be taken at the start of its quarter), so a whole
array of window times costs a few ``zoneinfo`` calls per hour it spans. The same lookup gives
FreMEn's clock (:meth:`Calendar.standard_ns`): UTC plus the daylight-saving shift.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta, timezone, tzinfo

import numpy as np
import numpy.typing as npt

from aion_cli.engine.temporal.zones import zone_of
from aion_cli.engine.types import I64
from aion_cli.errors import ConfigError

DAY_NS = 86_400 * 1_000_000_000
HOUR_NS = 3_600 * 1_000_000_000
QUARTER_NS = HOUR_NS // 4
"""Offsets are looked up per UTC quarter hour: every zone's offsets are whole quarter hours
and its rules change on a local quarter hour (St John's and Adelaide at a UTC half hour)."""
PROFILES = ("day", "day_weekend", "week")
_DAYS_PER_PROFILE = {"day": 1, "day_weekend": 2, "week": 7}


def weekday_of(day: npt.ArrayLike) -> I64:
    """Weekday (0 = Monday) of local day indices (days since 1970-01-01, a Thursday)."""
    out: I64 = np.mod(np.asarray(day, dtype=np.int64) + 3, 7)
    return out


@dataclass(frozen=True)
class Calendar:
    """Local days and profile bins of UNIX-nanosecond times (see the module docstring)."""

    timezone: str = "UTC"
    profile: str = "day_weekend"
    bin_s: float = 3600.0
    tz: tzinfo = field(init=False, repr=False, compare=False)
    bins_per_day: int = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.profile not in PROFILES:
            raise ConfigError(f"profile must be one of {', '.join(PROFILES)}, got {self.profile!r}")
        per_day = 86_400.0 / float(self.bin_s) if self.bin_s > 0 else 0.0
        if not (per_day >= 1 and abs(per_day - round(per_day)) < 1e-9):
            raise ConfigError(
                f"profile_bin_s must divide a day into whole bins, got {self.bin_s!r}",
                hint="e.g. 3600 (hours), 1800, 7200",
            )
        object.__setattr__(self, "tz", zone_of(self.timezone))
        object.__setattr__(self, "bins_per_day", round(per_day))

    @property
    def n_bins(self) -> int:
        """H, the number of profile bins."""
        return self.bins_per_day * _DAYS_PER_PROFILE[self.profile]

    @property
    def fixed(self) -> bool:
        """Whether the zone is UTC or a fixed offset (no daylight saving, no rule changes)."""
        return isinstance(self.tz, timezone)

    def local_ns(self, t_ns: npt.ArrayLike) -> I64:
        """Local wall-clock time as nanoseconds since 1970-01-01T00:00 local."""
        return self._shifted(t_ns, datetime.utcoffset)

    def standard_ns(self, t_ns: npt.ArrayLike) -> I64:
        """UTC plus the zone's daylight-saving shift at each time (``tzinfo.dst()``): the local
        clock less the zone's standard offset, FreMEn's clock (:meth:`TemporalParams.
        model_seconds <aion_cli.engine.temporal.params.TemporalParams.model_seconds>`). The
        times themselves in UTC and a fixed-offset zone."""
        if self.fixed:
            return np.asarray(t_ns, dtype=np.int64).copy()
        return self._shifted(t_ns, datetime.dst)

    def _shifted(self, t_ns: npt.ArrayLike, shift: Callable[[datetime], timedelta | None]) -> I64:
        """``t_ns`` plus ``shift`` of the local time, looked up once per distinct UTC quarter."""
        t = np.asarray(t_ns, dtype=np.int64)
        if self.tz is UTC or t.size == 0:
            return t.copy()
        quarters, inverse = np.unique(np.floor_divide(t, QUARTER_NS), return_inverse=True)
        offsets = np.fromiter(
            (self._shift_ns(int(q), shift) for q in quarters.tolist()),
            dtype=np.int64,
            count=quarters.size,
        )
        out: I64 = t + offsets[inverse.reshape(t.shape)]
        return out

    def _shift_ns(self, utc_quarter: int, shift: Callable[[datetime], timedelta | None]) -> int:
        moment = datetime(1970, 1, 1, tzinfo=UTC) + timedelta(minutes=15 * utc_quarter)
        delta = shift(moment.astimezone(self.tz)) or timedelta(0)
        return round(delta.total_seconds() * 1e9)

    def day(self, t_ns: npt.ArrayLike) -> I64:
        """Local day index (days since 1970-01-01 local)."""
        out: I64 = np.floor_divide(self.local_ns(t_ns), DAY_NS)
        return out

    def profile_bin(self, t_ns: npt.ArrayLike) -> I64:
        """Profile bin 0..H-1 of each time."""
        local = self.local_ns(t_ns)
        day = np.floor_divide(local, DAY_NS)
        in_day = np.floor_divide(local - day * DAY_NS, round(self.bin_s * 1e9))
        in_day = np.minimum(in_day, self.bins_per_day - 1)  # 23:00 of a 25 h day stays in bin 23
        weekday = weekday_of(day)
        if self.profile == "day":
            out: I64 = in_day
        elif self.profile == "day_weekend":
            out = in_day + self.bins_per_day * (weekday >= 5)
        else:
            out = in_day + self.bins_per_day * weekday
        return out.astype(np.int64)
