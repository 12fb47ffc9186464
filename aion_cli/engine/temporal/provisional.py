"""The pending day's day-ahead scores, for queries: the map's latest evidence, used at once.

A build scores a day only when it closes, when log time reaches the next local day: the last
day of a map stays *pending* (a later log may still add windows to it), unscored. Its windows
are data the model before it has not seen, so they are day-ahead evidence like any closed
day's — and without them a map of two days has no scored day at all, and forecasts with its
static rates whatever its rhythm. So a query scores the pending day as closing it would,
against the accumulators before it, *provisionally*: the contributions are added to the
scores the query chooses families by (:meth:`ProvisionalScores.applied_to`), never to the
map's own accumulators, which stay additive and exact for ``--map`` continuation and merges;
the day is scored for good when it closes.

The contributions are sums over the rows scored (``rows``, the live entries observed on the
day and before it) of the nine score fields of
:class:`~aion_cli.engine.temporal.accumulators.TemporalState`, computed on a scratch state that
shares the accumulators and starts its scores at zero. A map file stores them
(``provisional_*`` members, rows as positions in canonical order), so a query of a map read
without its Fourier sums — which FreMEn's scores need — chooses exactly as one of the map in
memory. One day's gains and day tallies follow from its scores and scored tallies, so only
those are stored (:data:`STORED`); the rest is derived on reading, bit for bit.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from aion_cli.engine.temporal.accumulators import _SCORES, _TALLIES, TemporalState
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import PendingDay
from aion_cli.engine.temporal.scoring import score_day, squared_gains
from aion_cli.engine.temporal.stored_layout import all_finite, narrowed, stored_positions
from aion_cli.engine.types import I64
from aion_cli.errors import MapCorruptError

PREFIX = "provisional_"
ROWS = PREFIX + "rows"
STORED = ("flow_score", "flow_chi2", "flow_scored", "dir_score", "dir_scored")
"""The fields a map stores; ``*_gain_sq`` and ``*_days`` are derived (:func:`_one_day`)."""


@dataclass(frozen=True)
class ProvisionalScores:
    """The pending day's score contributions: ``rows`` (sorted entry rows) and, per score
    field of :data:`_SCORES`, its values for those rows."""

    rows: I64
    fields: dict[str, np.ndarray]

    @classmethod
    def of_pending(
        cls,
        params: TemporalParams,
        state: TemporalState,
        pending: PendingDay,
        live_rows: I64,
        groups: I64,
        n_groups: int,
        window_ns: int,
    ) -> ProvisionalScores | None:
        """Score ``pending`` as closing it would (None when there is nothing to score)."""
        if not pending:
            return None
        # zeros are allocated lazily: only the scored rows' pages are ever touched
        zeros: dict[str, Any] = {name: np.zeros(getattr(state, name).shape) for name in _SCORES}
        scratch = dataclasses.replace(state, **zeros)
        rows = score_day(
            params, scratch, pending.consolidated(), live_rows, groups, n_groups, window_ns
        )
        if rows.size == 0:
            return None
        return cls(rows, {name: getattr(scratch, name)[rows] for name in _SCORES})

    def add_into(self, state: TemporalState) -> None:
        """Add the contributions to ``state``'s scores, in place (the same additions as
        closing the day makes). Rows 0..n−1 (a fixed sensor's day scores every entry) are
        added as one slice, without gathering and scattering them."""
        n = self.rows.size
        every = slice(0, n) if n and int(self.rows[-1]) == n - 1 else self.rows  # increasing
        for name in _SCORES:
            getattr(state, name)[every] += self.fields[name]
        state.touch()

    def applied_to(self, state: TemporalState) -> TemporalState:
        """``state`` with the contributions added to copies of its scores (the accumulators
        are shared, not copied: the result is for reading scores only)."""
        copies: dict[str, Any] = {name: getattr(state, name).copy() for name in _SCORES}
        out = dataclasses.replace(state, **copies)
        self.add_into(out)
        return out

    # -- persistence ------------------------------------------------------------------------
    def to_arrays(self, position: I64) -> dict[str, np.ndarray]:
        """Members for a map whose entries are written in canonical order (``position``:
        entry row -> index in that order)."""
        at = position[self.rows]
        order = np.argsort(at, kind="stable")
        out = {ROWS: stored_positions(at[order].astype(np.int64), position.size)}
        for name in STORED:
            values = self.fields[name][order]
            if name in _TALLIES:
                values = np.asarray(narrowed(values, np.arange(values.size)))
            out[PREFIX + name] = values
        return out

    @classmethod
    def from_arrays(
        cls, arrays: Mapping[str, np.ndarray], n_entries: int, params: TemporalParams
    ) -> ProvisionalScores | None:
        """The stored contributions (None when the map has none); entry rows are the
        canonical positions, as a map read back numbers its entries.
        :class:`MapCorruptError` when they are inconsistent."""
        if ROWS not in arrays:
            return None
        rows = np.asarray(arrays[ROWS])
        widths = {"flow": len(params.flow), "dir": len(params.direction)}
        try:
            fields = {name: np.asarray(arrays[PREFIX + name], np.float64) for name in STORED}
        except KeyError as exc:
            raise MapCorruptError(f"the map's provisional scores lack {exc}") from exc
        problem = None
        if rows.ndim != 1 or rows.dtype.kind not in "iu":
            problem = "their rows are not a list of integers"
        else:  # stored narrow (uint32): differences must not wrap around
            rows = rows.astype(np.int64)
            if rows.size and (rows[0] < 0 or rows[-1] >= n_entries or np.any(np.diff(rows) <= 0)):
                problem = "their rows are not increasing positions of the map's entries"
        for name, values in fields.items():
            width = widths[name.split("_")[0]]
            shape = (rows.size,) if name in _TALLIES else (rows.size, width)
            if problem is None and values.shape != shape:
                problem = f"{name} has shape {values.shape}, expected {shape}"
            elif problem is None and not all_finite(values):
                problem = f"{name} has values that are not finite"
            elif problem is None and name in _TALLIES and (values < 0).any():
                problem = f"{name} has negative values"
        if problem is not None:
            raise MapCorruptError(f"the map's provisional scores are inconsistent: {problem}")
        static = (params.flow.index("static"), params.direction.index("static"))
        fields.update(_one_day(fields, "flow", static[0]))
        fields.update(_one_day(fields, "dir", static[1]))
        return cls(rows.astype(np.int64), fields)


def _one_day(fields: dict[str, np.ndarray], kind: str, static: int) -> dict[str, np.ndarray]:
    """One day's ``{kind}_gain_sq`` and ``{kind}_days`` from its scores and tally, as
    scoring adds them (``scoring._add_day``: the squared gain over ``static``, and a day for
    every row that had something scored), so the stored contributions need not hold them."""
    days = (fields[f"{kind}_scored"] > 0).astype(np.float64)
    return {f"{kind}_gain_sq": squared_gains(fields[f"{kind}_score"], static), f"{kind}_days": days}
