"""Look-ahead for differenced headings: a track's first rows wait for its first displacement.

:class:`~aion_cli.engine.heading.HeadingEstimator` is causal: a row's heading comes from a
displacement that ends at or before it, so the rows at the start of a track (and after its
reference lapsed) have none yet -- they *wait* -- while the offline rule
(:func:`aion_cli.engine.differencing.difference_tracks`) looks ahead and gives them the
direction of the track's first displacement. With ``look_ahead`` the estimator says, per row
(:class:`LookAhead`), whether it waits, when its reference lapses, and whether it *settles*
its track's waiting rows (the displacement that ends the wait, or the lapse, NaN); a
:class:`HeadingHold` between the decoding and the Mapper holds the waiting rows back and
gives them the settling heading, and the speed of the same displacement, when it comes.

The hold is a first-in first-out queue of rows: rows leave in the order they came, so the
Mapper receives exactly the rows, in exactly the order, it would without the hold, only some
of them one piece later. A waiting row leaves when its track settles (with that heading),
when the stream's time passes its reference's time plus ``max_gap`` (the reference lapsed:
no heading, as without the hold) or when the caller releases everything (:meth:`HeadingHold.
release`, at the end of the stream). What the caller must put between rows (a scene graph,
which the Mapper applies between the rows before and after it) waits behind the rows held
when it came, and goes on once :attr:`HeadingHold.left` counts them all: a graph no longer
empties the hold, so a track that starts just before it still gets its heading. Memory
stays bounded: the queue starts at its oldest waiting row, whose reference lapses
``max_gap`` of stream time later, so it holds at most the rows of ``max_gap`` seconds (5 s
for linked tracks) plus one piece, and the caller the graphs of those seconds. Where a track
settles depends on the rows only, never on how the stream was cut into pieces or decode jobs
or where the graphs came.
Pure numpy: each push is a few sorts and searches over the queued rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aion_cli.engine.types import F64, I64, BoolA, DetectionBatch


@dataclass(frozen=True)
class LookAhead:
    """Per row of a batch: ``key`` the track it waits on or settles (-1: none), ``waiting``
    (its heading waits for the track's next displacement), ``expire_ns`` (a waiting row's
    reference time plus ``max_gap``), ``settles`` (the row ends its track's wait),
    ``heading`` (a settling row's heading for the waiting rows; NaN: none, the reference
    lapsed) and ``speed`` (the speed of the same displacement, m/s)."""

    key: I64
    waiting: BoolA
    expire_ns: I64
    settles: BoolA
    heading: F64
    speed: F64

    @classmethod
    def none(cls, n: int) -> LookAhead:
        """``n`` rows that neither wait nor settle."""
        return cls(np.full(n, -1, np.int64), np.zeros(n, bool), np.zeros(n, np.int64),
                   np.zeros(n, bool), np.full(n, np.nan), np.full(n, np.nan))

    def __len__(self) -> int:
        return len(self.key)

    def select(self, index: I64 | BoolA | slice) -> LookAhead:
        """The rows ``index`` (indices or a mask), in that order."""
        return LookAhead(self.key[index], self.waiting[index], self.expire_ns[index],
                         self.settles[index], self.heading[index], self.speed[index])

    def put(self, index: I64, other: LookAhead) -> None:
        """Rows ``index`` of this one set to ``other``'s (in place)."""
        self.key[index], self.waiting[index] = other.key, other.waiting
        self.expire_ns[index], self.settles[index] = other.expire_ns, other.settles
        self.heading[index], self.speed[index] = other.heading, other.speed

    def rekeyed(self, label: I64, n_labels: int) -> LookAhead:
        """Keys made unique over several sources (``label`` per row, ``0 .. n_labels - 1``)."""
        key = np.where(self.key >= 0, self.key * n_labels + label, -1)
        return LookAhead(key, self.waiting, self.expire_ns, self.settles, self.heading,
                         self.speed)

    @staticmethod
    def concat(parts: list[LookAhead]) -> LookAhead:
        return LookAhead(*(np.concatenate([getattr(p, f) for p in parts]) for f in
                           ("key", "waiting", "expire_ns", "settles", "heading", "speed")))


class HeadingHold:
    """The queue of the module docstring. :meth:`push` a decoded piece (its rows, a label per
    row and their :class:`LookAhead`), get back the rows that leave now; :meth:`release`
    empties it. :attr:`settled` counts, per label, the rows that got a heading here (a
    build moves them from its 'none' to its 'linked' heading count)."""

    def __init__(self) -> None:
        self._batch = DetectionBatch.empty()
        self._label: I64 = np.zeros(0, np.int64)
        self._look = LookAhead.none(0)
        self.settled: dict[int, int] = {}
        #: rows that have left, in all (where a caller places what it keeps between rows)
        self.left = 0

    def __len__(self) -> int:
        """Rows held."""
        return len(self._batch)

    def push(
        self, batch: DetectionBatch, label: I64, look: LookAhead
    ) -> tuple[DetectionBatch, I64]:
        """Queue ``batch`` and return the rows (and their labels) that leave now."""
        if len(self._batch) == 0 and not look.waiting.any():
            self.left += len(batch)
            return batch, label  # nothing waits: the rows pass straight through
        if len(self._batch):
            batch = DetectionBatch.concat([self._batch, batch])
            label = np.concatenate([self._label, label])
            look = LookAhead.concat([self._look, look])
        return self._leave(batch, label, look, everything=False)

    def release(self) -> tuple[DetectionBatch, I64]:
        """Every row held, in order: waiting rows whose track settled among them get its
        heading, the others none."""
        return self._leave(self._batch, self._label, self._look, everything=True)

    def _leave(
        self, batch: DetectionBatch, label: I64, look: LookAhead, everything: bool
    ) -> tuple[DetectionBatch, I64]:
        n = len(batch)
        pos = np.arange(n)
        leave_at = pos.copy()
        heading = batch.heading.copy()
        speed = batch.speed
        wait = np.flatnonzero(look.waiting)
        if wait.size:
            at, h, v = _settling(look, wait, n)
            # the reference lapses at the first row the stream's time passes its expiry
            lapse = np.searchsorted(np.maximum.accumulate(batch.t_ns), look.expire_ns[wait],
                                    side="right")
            lapse = np.maximum(lapse, wait)
            got = at <= lapse  # (a settling row is never one past the expiry: it would lapse)
            leave_at[wait] = np.minimum(at, lapse)
            given = got & (at < n)
            heading[wait] = np.where(given, h, np.nan)
            # the speed of the displacement that gave the heading, as the settling row has
            speed = speed.copy()
            speed[wait[given]] = v[given]
        if everything:
            m = n
        else:
            m = int(np.searchsorted(np.maximum.accumulate(leave_at), n))
        out = DetectionBatch(batch.t_ns[:m], batch.xyz[:m], heading[:m], speed[:m],
                             batch.track_id[:m])
        given = look.waiting[:m] & ~np.isnan(heading[:m])
        if given.any():
            for lab, k in zip(*np.unique(label[:m][given], return_counts=True), strict=True):
                self.settled[int(lab)] = self.settled.get(int(lab), 0) + int(k)
        rest = np.arange(m, n)
        self._batch = DetectionBatch(batch.t_ns[rest], batch.xyz[rest], batch.heading[rest],
                                     batch.speed[rest], batch.track_id[rest])
        self._label, self._look = label[rest], look.select(rest)
        self.left += m
        return out, label[:m]


def _settling(look: LookAhead, wait: I64, n: int) -> tuple[I64, F64, F64]:
    """For each waiting row ``wait``: the position of the first later row of its track that
    settles (``n`` if none yet) and that row's heading and speed."""
    settle = np.flatnonzero(look.settles)
    at = np.full(len(wait), n, np.int64)
    h = np.full(len(wait), np.nan)
    v = np.full(len(wait), np.nan)
    if settle.size == 0:
        return at, h, v
    _, rank = np.unique(look.key[np.concatenate([wait, settle])], return_inverse=True)
    w_rank, s_rank = rank[: len(wait)], rank[len(wait):]
    s_code = s_rank * (n + 1) + settle  # (key, position), increasing in both
    order = np.argsort(s_code, kind="stable")
    s_code, s_pos = s_code[order], settle[order]
    j = np.searchsorted(s_code, w_rank * (n + 1) + wait, side="right")
    ok = j < len(s_code)
    ok[ok] = s_code[j[ok]] // (n + 1) == w_rank[ok]
    at[ok] = s_pos[j[ok]]
    h[ok] = look.heading[s_pos[j[ok]]]
    v[ok] = look.speed[s_pos[j[ok]]]
    return at, h, v
