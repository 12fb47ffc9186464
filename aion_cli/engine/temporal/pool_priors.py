"""The pooling's estimated prior strengths, kept with the map so that a query need not
estimate them again (issue 15, stop 69).

A forecast shrinks each entry's direction histogram toward its group's with κ, an hour's
toward the entry's static one with κ_t, and a group's hour toward its static histogram with
κ_G (:mod:`.direction_prior`, :mod:`.group_shift`). With ``"auto"`` they are estimated from the
accumulators as a query sees them (pending day and open window absorbed): three maximum
marginal likelihood searches over thousands of hashed samples, a fifth of a second on a map
of 10^5 entries, every query. They depend on the accumulators only, so a map stores them,
computed when it is written (``engine.view_priors``, from the very view a query of the file
builds): the ``forecast_priors`` member, float64 [5]: κ, κ_t, κ_G (NaN: no group's hours
differ, no shift), and the numbers of entries and groups they were pooled over (a query uses
them only when its own agree).

Derived data, like the FreMEn components: every write computes them afresh (a build, its
continuation with ``--map``, a merge, a parallel build's join), never copies them from a map
read; a map without them (written before stop 69, or by hand) is read as before and its query
estimates them. A query with them forecasts exactly as one that estimates them (tested).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from aion_cli.errors import MapCorruptError

MEMBER = "forecast_priors"


@dataclass(frozen=True)
class PoolPriors:
    """κ, κ_t and κ_G (None: no shift) as estimated over ``entries`` entries in ``groups``
    pooling groups."""

    kappa: float
    kappa_t: float
    kappa_g: float | None
    entries: int
    groups: int

    def fits(self, entries: int, groups: int) -> bool:
        """Whether these were pooled over as many entries and groups as a query pools."""
        return self.entries == entries and self.groups == groups

    def to_arrays(self) -> dict[str, Any]:
        kappa_g = np.nan if self.kappa_g is None else self.kappa_g
        values = [self.kappa, self.kappa_t, kappa_g, self.entries, self.groups]
        return {MEMBER: np.array(values, np.float64)}

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, np.ndarray]) -> PoolPriors | None:
        """The stored priors, None when the map has none; :class:`MapCorruptError` when they
        are not five numbers: two not negative, κ_G positive or NaN, two counts."""
        if MEMBER not in arrays:
            return None
        values = np.asarray(arrays[MEMBER])
        if values.shape != (5,) or values.dtype != np.float64:
            raise MapCorruptError(
                f"map member {MEMBER} has shape {values.shape} and dtype {values.dtype}, "
                "expected (5,) float64"
            )
        kappa, kappa_t, kappa_g, entries, groups = (float(v) for v in values)
        counts_ok = all(np.isfinite(c) and c >= 0 and c == int(c) for c in (entries, groups))
        if not (kappa >= 0 and kappa_t >= 0 and np.isfinite(kappa) and np.isfinite(kappa_t)
                and (np.isnan(kappa_g) or 0 < kappa_g < np.inf) and counts_ok):  # fmt: skip
            raise MapCorruptError(
                f"map member {MEMBER} holds {values.tolist()}: expected κ and κ_t not negative, "
                "κ_G positive or NaN, and two counts"
            )
        return cls(kappa, kappa_t, None if np.isnan(kappa_g) else kappa_g,
                   int(entries), int(groups))  # fmt: skip
