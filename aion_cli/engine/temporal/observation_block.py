"""The observation sums of entry rows: which windows saw each entry (one job of the temporal
accumulators, :mod:`~aion_cli.engine.temporal.accumulators`, kept apart because every
accumulator operation and the map file use it alike).

Per row: ``n`` (windows observed), ``fourier[K]`` = Σ e^{iω_k t_w} over those windows,
``profile[H]`` = windows per profile bin, ``first`` / ``last`` (model seconds, NaN before any).
Sums (and min / max), so blocks of disjoint time add exactly.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.temporal.stored_layout import stored_member
from aion_cli.engine.types import F64, I64, RowTake
from aion_cli.engine.zeros import lazy_zeros
from aion_cli.errors import MapCorruptError

C128 = npt.NDArray[np.complex128]

_OBS_FIELDS = ("n", "fourier", "profile", "first", "last")


@dataclass
class ObsBlock:
    """Observation sums of R rows over K periods and H profile bins (see module docstring)."""

    n: F64
    fourier: C128
    profile: F64
    first: F64
    last: F64

    @classmethod
    def empty(cls, rows: int, periods: int, bins: int) -> ObsBlock:
        return cls(
            lazy_zeros(rows),
            lazy_zeros((rows, periods), np.complex128),
            lazy_zeros((rows, bins)),
            np.full(rows, np.nan),
            np.full(rows, np.nan),
        )

    def take(self, rows: npt.ArrayLike, fourier: bool = True) -> ObsBlock:
        """Copies of rows ``rows``; without ``fourier`` the Fourier sums are left out (shape
        ``(n, 0)``)."""
        r = np.asarray(rows, dtype=np.int64)
        if fourier:
            return ObsBlock(*(getattr(self, f)[r].copy() for f in _OBS_FIELDS))
        return ObsBlock(
            self.n[r].copy(),
            np.zeros((r.size, 0), np.complex128),
            self.profile[r].copy(),
            self.first[r].copy(),
            self.last[r].copy(),
        )

    def put(self, rows: I64, other: ObsBlock) -> None:
        for f in _OBS_FIELDS:
            getattr(self, f)[rows] = getattr(other, f)

    def add_block(self, rows: I64, other: ObsBlock) -> None:
        """``self[rows] += other`` (repeated rows accumulate; first = min, last = max)."""
        np.add.at(self.n, rows, other.n)
        np.add.at(self.fourier, rows, other.fourier)
        np.add.at(self.profile, rows, other.profile)
        np.fmin.at(self.first, rows, other.first)
        np.fmax.at(self.last, rows, other.last)

    def zero(self, rows: I64) -> None:
        self.n[rows] = 0.0
        self.fourier[rows] = 0.0
        self.profile[rows] = 0.0
        self.first[rows] = np.nan
        self.last[rows] = np.nan

    def to_arrays(self, prefix: str, rows: I64 | None = None) -> dict[str, Any]:
        if rows is None:
            return {prefix + f: getattr(self, f) for f in _OBS_FIELDS}
        return {prefix + f: RowTake(getattr(self, f), rows) for f in _OBS_FIELDS}

    @classmethod
    def from_arrays(
        cls,
        arrays: Mapping[str, np.ndarray],
        prefix: str,
        rows: int,
        periods: int,
        bins: int,
        copy: bool = True,
        fourier: bool = True,
    ) -> ObsBlock:
        """Inverse of :meth:`to_arrays`; without ``fourier`` the Fourier member is not read
        (the block's sums then have shape ``(rows, 0)``)."""
        shapes = {
            "n": (rows,),
            "fourier": (rows, periods),
            "profile": (rows, bins),
            "first": (rows,),
            "last": (rows,),
        }
        if not fourier:
            del shapes["fourier"]
        vals = {f: stored_member(arrays, prefix + f, shape, copy) for f, shape in shapes.items()}
        if not fourier:
            vals["fourier"] = np.zeros((rows, 0), np.complex128)
        if vals["fourier"].dtype != np.complex128:
            raise MapCorruptError(f"{prefix}fourier must be complex128")
        return cls(**vals)
