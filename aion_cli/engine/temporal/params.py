"""The temporal model's parameters and family names, derived once from a ModelConfig.

Flow families (the expected number of detections per observed window), simplest first:

* ``static`` — λ = N / W, the entry's historical rate;
* ``shape`` — the static rate times its parent group's periodic shape (a sparse entry borrows
  *when* its room or neighbourhood is busy);
* ``fremen1`` … ``fremenM`` — FreMEn on the rate with the m strongest periods of the entry's
  total spectrum (the paper's model);
* ``profile`` — the entry's own periodic profile (hour of day × weekday/weekend by default),
  shrunk toward the ``shape`` forecast with ``profile_prior`` pseudo-detections per profile
  bin.

Direction families (the histogram of walking directions): ``static`` (the entry's historical
histogram under a Dirichlet prior centred on its group's, itself centred on the map's),
``fremen1``, ``fremen2`` (per-bin FreMEn rates, at most :data:`DIRECTION_ORDERS` periods per
bin) and ``profile`` (per-bin counts in the profile bin), both shrunk toward the static
histogram modulated by the group's hour (:mod:`~aion_cli.engine.temporal.group_shift`) with
``direction_time_prior`` pseudo-detections (κ_t; ``"auto"``: estimated from
the map, :func:`~aion_cli.engine.temporal.direction_prior.time_prior`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal.calendar import Calendar
from aion_cli.engine.temporal.spectrum import omega
from aion_cli.engine.types import F64
from aion_cli.engine.windows import to_model_seconds

FAMILY_KINDS = ("static", "shape", "fremen", "profile")


def flow_families(max_order: int) -> tuple[str, ...]:
    return ("static", "shape", *(f"fremen{m}" for m in range(1, max_order + 1)), "profile")


DIRECTION_ORDERS = 2
"""Per-bin FreMEn directions use at most this many periods per bin: a direction bin's series is
a fraction of its entry's, and higher orders only fit its noise (they also cost the most)."""


def direction_families(max_order: int) -> tuple[str, ...]:
    orders = min(max_order, DIRECTION_ORDERS)
    return ("static", *(f"fremen{m}" for m in range(1, orders + 1)), "profile")


def _kind(name: str) -> str:
    return "fremen" if name.startswith("fremen") else name


@dataclass(frozen=True)
class TemporalParams:
    """Everything the temporal model needs from the config, precomputed."""

    config: ModelConfig
    calendar: Calendar = field(init=False)
    omega: F64 = field(init=False, repr=False)
    min_span: F64 = field(init=False, repr=False)
    flow: tuple[str, ...] = field(init=False)
    direction: tuple[str, ...] = field(init=False)
    flow_enabled: np.ndarray = field(init=False, repr=False)
    direction_enabled: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        cfg = self.config
        set_ = object.__setattr__
        set_(self, "calendar", Calendar(cfg.timezone, cfg.profile, cfg.profile_bin_s))
        periods = np.asarray(cfg.periods, dtype=np.float64)
        set_(self, "omega", omega(periods))
        set_(self, "min_span", cfg.span_factor * periods)
        flow = flow_families(self.max_order)
        direction = direction_families(self.max_order)
        set_(self, "flow", flow)
        set_(self, "direction", direction)
        enabled = set(cfg.families) | {"static"}
        set_(self, "flow_enabled", np.array([_kind(f) in enabled for f in flow]))
        direction_on = enabled - {"shape"}
        set_(self, "direction_enabled", np.array([_kind(f) in direction_on for f in direction]))

    @classmethod
    def from_config(cls, config: ModelConfig) -> TemporalParams:
        return cls(config)

    def model_seconds(self, t_ns: npt.ArrayLike) -> F64:
        """FreMEn's time of UNIX-ns times, model seconds on the map's ``fremen_clock``: UTC
        plus the zone's daylight-saving shift (``"standard"``: a routine keeps its phase across
        a clock change; in UTC and a fixed offset exactly :func:`~aion_cli.engine.windows.
        to_model_seconds`), or UTC (``"utc"``, maps built before the key). Every phase e^{iωt}
        of the map is taken at these times; spans and observed ends stay on UTC."""
        if self.config.fremen_clock == "utc" or self.calendar.fixed:
            return to_model_seconds(t_ns)
        return to_model_seconds(self.calendar.standard_ns(t_ns))

    @property
    def bins(self) -> int:
        """B, the direction bins."""
        return self.config.bins

    @property
    def values(self) -> int:
        """V = B + 1 value bins (directions, then detections without a heading)."""
        return self.config.bins + 1

    @property
    def max_order(self) -> int:
        """M, the highest FreMEn order (limited by the number of periods)."""
        return min(self.config.max_order, len(self.config.periods))

    @property
    def n_periods(self) -> int:
        return len(self.config.periods)

    @property
    def n_profile(self) -> int:
        return self.calendar.n_bins
