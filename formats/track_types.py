"""What every tracks module shares: the layout names, the error, and a file's data.

The readers (:mod:`formats.track_csv`, :mod:`formats.datasets`), the dispatch over them
(:mod:`formats.tracks`) and the log writer (:mod:`formats.tracks_log`) all use these, so they
sit below all of them, in a module that imports none of them:

- :data:`LAYOUTS`: the layouts :func:`formats.tracks.read_track_data` reads (an error names
  them, whichever reader raised it); :data:`RELATIVE_TIME_LAYOUTS`: those counting from 0.
- :class:`TracksFormatError`: a tracks file that cannot be read.
- :class:`TrackData`: a file read whole, its detections and the spans in which the sensor was
  recording; :func:`merge_spans` joins such spans, :func:`sessions` finds recording sessions
  in header-less files.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.spatial_hash import BIAS
from aion_cli.engine.time_text import utc_of
from aion_cli.engine.types import F64, DetectionBatch
from aion_cli.errors import InputError

Layout = Literal[
    "canonical", "atc", "thor", "eth", "ucy", "lincoln", "edinburgh", "thor-magni"
]
LAYOUTS: tuple[str, ...] = (
    "canonical",
    "atc",
    "thor",
    "eth",
    "ucy",
    "lincoln",
    "edinburgh",
    "thor-magni",
)
#: layouts whose times count from 0 (the recording's start), not from the UNIX epoch
RELATIVE_TIME_LAYOUTS: tuple[str, ...] = ("thor", "eth", "ucy", "edinburgh", "thor-magni")


class TracksFormatError(InputError):
    """A tracks file has the wrong layout, non-numeric data, or no rows."""


class NegativeTrackIdError(InputError):
    """A track id below 0 where the message type written needs ids of 0 or more (spencer
    ``TrackedPersons``); ``aion convert`` names the file's line that holds it."""


class NoTrackRowsError(TracksFormatError):
    """A tracks file holds no detection row (empty, a header or comments only): with
    ``--observed`` spans, a sensor that ran while nobody came. ``declared``: the spans the
    file itself declares as recorded (a Lincoln header), which count as such spans."""

    declared: tuple[tuple[int, int], ...] = ()


@dataclass(frozen=True)
class TrackData:
    """A tracks file read whole: its detections and when the sensor was recording.

    ``observed`` lists sorted, disjoint, half-open ``[start, end)`` UNIX-ns spans in which the
    sensor ran (empty: the file does not say; do not take its time span as observed).
    ``notes`` are one-line remarks about the file for the user. ``detector_heading`` is a
    heading column the file itself carries (rad, aligned with ``batch`` rows), else None.
    """

    batch: DetectionBatch
    observed: list[tuple[int, int]] = field(default_factory=list)
    notes: tuple[str, ...] = ()
    detector_heading: F64 | None = None


def merge_spans(spans: Iterable[tuple[int, int]]) -> list[tuple[int, int]]:
    """Sorted union of half-open ``[start, end)`` spans (overlapping or touching ones joined).

    Raises :class:`InputError` for a span whose end is not after its start.
    """
    items = sorted((int(a), int(b)) for a, b in spans)
    for a, b in items:
        if b <= a:
            raise InputError(
                f"observed span {a}..{b} ns ends before it starts",
                hint="give each span as START..END with END after START",
            )
    merged: list[tuple[int, int]] = []
    for a, b in items:
        if merged and a <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], b))
        else:
            merged.append((a, b))
    return merged


def sessions(t_ns: npt.ArrayLike, gap_ns: int) -> list[tuple[int, int]]:
    """Recording sessions of a set of detection times: the times split wherever two successive
    detections are more than ``gap_ns`` apart, each session spanning ``[first, last + 1 ns)``
    (half-open, so its last detection is inside).

    Used to declare what a header-less dataset observed: a corridor dataset recorded on
    several days has sessions of hours separated by nights. Empty input: no sessions.
    """
    if not gap_ns > 0:
        raise InputError(f"the session gap must be > 0 ns, got {gap_ns}")
    t = np.unique(np.asarray(t_ns, dtype=np.int64))
    if t.size == 0:
        return []
    cut = np.flatnonzero(np.diff(t) > gap_ns)
    starts = np.concatenate([[0], cut + 1])
    ends = np.concatenate([cut, [len(t) - 1]])
    return [(int(a), int(b) + 1) for a, b in zip(t[starts], t[ends], strict=True)]


def _utc(t_ns: int) -> str:
    """``2026-01-05 08:00:00``: a UNIX-ns time cut to the second (not rounded up to the next
    through float seconds: :func:`aion_cli.engine.time_text.utc_of`)."""
    return utc_of(t_ns).strftime("%Y-%m-%d %H:%M:%S")


def repeated_rows(batch: DetectionBatch) -> tuple[npt.NDArray[np.bool_], int]:
    """Rows that repeat the time and track id of an earlier row (ids >= 0; -1 is no id), and
    how many of those lie elsewhere than that earlier row. One person is at one place at a
    time: such rows come from a file that holds its rows (or some) twice, and would count
    the person twice in every flow (and, for layouts differenced into headings, leave
    zero time steps)."""
    n = len(batch.t_ns)
    repeated = np.zeros(n, dtype=bool)
    ided = np.flatnonzero(batch.track_id >= 0)
    if len(ided) < 2:
        return repeated, 0
    order = ided[np.lexsort((ided, batch.track_id[ided], batch.t_ns[ided]))]
    t, k = batch.t_ns[order], batch.track_id[order]
    same = np.concatenate([[False], (t[1:] == t[:-1]) & (k[1:] == k[:-1])])
    if not same.any():
        return repeated, 0
    first = np.maximum.accumulate(np.where(same, 0, np.arange(len(order))))
    repeated[order[same]] = True
    xyz = batch.xyz[order]
    elsewhere = same & np.any(xyz != xyz[first], axis=1)
    return repeated, int(elsewhere.sum())


FAR_M = float(BIAS * ModelConfig.cell_size)  # the dataclass default, 0.5 m
"""How far from the origin a position may lie before :class:`FarRows` counts it: where the
build's spatial hash ends at the default cell size (2^20 cells of 0.5 m, 524 km). A dataset
position beyond it is a damaged value or not in metres (1e300, a GPS easting)."""


@dataclass
class FarRows:
    """Counts the rows whose position lies more than :data:`FAR_M` from the origin on some
    axis, over the batches, with the first such coordinate as an example (they are written
    as the file has them; ``aion build`` leaves out what its spatial hash cannot hold)."""

    rows: int = 0
    example: float = 0.0

    def count(self, data: DetectionBatch) -> None:
        far = np.abs(data.xyz) > FAR_M
        rows = far.any(axis=1)
        if not rows.any():
            return
        if self.rows == 0:
            self.example = float(data.xyz[far][0])
        self.rows += int(rows.sum())


@dataclass
class RepeatedRows:
    """Leaves out the rows that repeat an earlier row's time and track id
    (:func:`repeated_rows`) from each batch of whole messages, counting them over the
    batches (``elsewhere``: those at another position)."""

    rows: int = 0
    elsewhere: int = 0

    def drop(self, data: DetectionBatch) -> DetectionBatch:
        mask, elsewhere = repeated_rows(data)
        if not mask.any():
            return data
        self.rows += int(mask.sum())
        self.elsewhere += elsewhere
        return data.select(~mask)


@dataclass
class DistinctIds:
    """Counts the distinct track ids over a stream of batches. ``np.union1d`` of everything
    seen with each batch sorts every id seen once per batch, a cost that grows with the
    square of a file's length (0.85 s of a 3.1 M-row ATC convert); here each batch's
    distinct ids wait and are merged once they outnumber the ids merged so far, so each id
    is sorted a few times, and memory stays about twice the distinct ids."""

    merged: npt.NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    pending: list[npt.NDArray[np.int64]] = field(default_factory=list)
    waiting: int = 0  # ids in pending

    def add(self, track_id: npt.NDArray[np.int64]) -> None:
        distinct = np.unique(track_id)
        self.pending.append(distinct)
        self.waiting += len(distinct)
        if self.waiting > len(self.merged):
            self._merge()

    def _merge(self) -> None:
        self.merged = np.unique(np.concatenate([self.merged, *self.pending]))
        self.pending, self.waiting = [], 0

    def __len__(self) -> int:
        self._merge()
        return len(self.merged)
