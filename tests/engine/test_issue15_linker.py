"""Issue 15, the track linker's per-frame work (id-less detections: PoseArray, leg
detectors, the Lincoln files): ``TrackLinker`` with less Python and numpy overhead per frame
links exactly as the code it replaced (a verbatim copy below) -- the same ids and the same
track state to the bit, over random streams with crowded frames (ambiguous gates, the
optimal assignment), repeated and backward-jittering stamps, far-out and non-finite
positions, linked in chunks -- and takes the shortcuts: the overflow guard is entered once
per call, not once per frame, and the assignment's sub-matrix is picked without ``np.ix_``.
"""

from __future__ import annotations

from itertools import pairwise
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine import tracking
from aion_cli.engine.tracking import _BIG, _NS, LinkerConfig, TrackLinker, _frames, _inputs
from aion_cli.engine.types import F64, I64

S = 1_000_000_000
T0 = 1_351_038_020 * S


class _LinkerBefore(TrackLinker):
    """``TrackLinker``'s frame loop before issue 15's overhead cuts (verbatim)."""

    def link(self, t_ns: npt.ArrayLike, xy: npt.ArrayLike) -> I64:
        """Track ids of the next detections (``t_ns`` int64 ns, ``xy`` [n, 2] or [n, 3] m),
        aligned with the input rows; :class:`InputError` for arrays of the wrong shape."""
        t, p = _inputs(t_ns, xy)
        out = np.full(len(t), -1, np.int64)
        rows = np.flatnonzero(np.isfinite(p).all(axis=1))
        if rows.size == 0:
            return out
        if rows.size > 1 and not bool(np.all(t[rows][1:] >= t[rows][:-1])):
            rows = rows[np.argsort(t[rows], kind="stable")]
        ts, ps = t[rows], p[rows]
        ids = np.empty(len(rows), np.int64)
        for a, b, now in zip(*_frames(ts), strict=True):
            ids[a:b] = self._frame(now, ps[a:b])
        out[rows] = ids
        return out

    def _frame(self, now: int, det: F64) -> I64:
        """Associate one frame's detections with the live tracks (see :func:`_associate`)."""
        cfg = self.config
        n = self._n
        if n:
            alive = self._t[:n] >= now - self._gap_ns
            if not alive.all():
                self._keep(alive)
                n = self._n
        m = len(det)
        if n == 0:
            return self._start(now, det)
        dt_s = np.maximum(now - self._t[:n], 0).astype(np.float64) * _NS
        pred = self._xy[:n] + self._v[:n] * dt_s[:, None]
        dx = pred[:, 0, None] - det[None, :, 0]
        dy = pred[:, 1, None] - det[None, :, 1]
        with np.errstate(over="ignore"):  # positions far out (1e300 m) are no match: inf
            d2 = dx * dx + dy * dy
        gate = cfg.max_speed * dt_s + cfg.gate_slack
        gated = d2 <= (gate * gate)[:, None]
        out = np.empty(m, np.int64)
        per_row = gated.sum(axis=1)
        if not per_row.any():
            out[:] = self._start(now, det)
            return out
        per_col = gated.sum(axis=0)
        if per_row.max() == 1 and per_col.max() == 1:
            r, c = np.nonzero(gated)  # every gated pair is the only one of its row and column
        else:
            r, c = self._assign(gated, d2, np.flatnonzero(per_row), np.flatnonzero(per_col))
        out[c] = self._ids[r]
        self._extend(r, now, det[c], dt_s[r])
        if len(c) < m:
            rest = np.ones(m, dtype=bool)
            rest[c] = False
            out[rest] = self._start(now, det[rest])
        return out

    @staticmethod
    def _assign(
        gated: npt.NDArray[np.bool_], d2: F64, rows_in: I64, cols_in: I64
    ) -> tuple[I64, I64]:
        """Track rows and detection columns matched: the cheapest one-to-one assignment of
        gated pairs (most pairs first, then the least total distance), solved only over the
        rows and columns that have a gated pair."""
        sub = gated[np.ix_(rows_in, cols_in)]
        dist = np.sqrt(d2[np.ix_(rows_in, cols_in)])
        if len(rows_in) == 1 or len(cols_in) == 1:  # the best gated pair is optimal
            flat = int(np.argmin(np.where(sub, dist, np.inf)))
            r, c = np.divmod(np.array([flat]), len(cols_in))
        else:
            from scipy.optimize import linear_sum_assignment

            r, c = linear_sum_assignment(np.where(sub, dist, _BIG))
            keep = sub[r, c]
            r, c = r[keep], c[keep]
        return rows_in[r], cols_in[c]

    def _keep(self, mask: npt.NDArray[np.bool_]) -> None:
        """Compact the live tracks to those of ``mask`` (their order kept)."""
        k = int(mask.sum())
        for arr in (self._ids, self._t, self._count, self._xy, self._v):
            arr[:k] = arr[: self._n][mask]
        self._n = k

    def _start(self, now: int, xy: F64) -> I64:
        """New tracks at ``xy`` (stationary until matched), appended to the live ones."""
        k = len(xy)
        a, b = self._n, self._n + k
        if b > len(self._ids):
            self._grow(b)
        new = np.arange(self.next_id, self.next_id + k, dtype=np.int64)
        self.next_id += k
        self._ids[a:b], self._t[a:b], self._xy[a:b] = new, now, xy
        self._v[a:b], self._count[a:b] = 0.0, 1
        self._n = b
        return new

    def _grow(self, needed: int) -> None:
        cap = max(needed, 2 * len(self._ids))
        for name in ("_ids", "_t", "_count", "_xy", "_v"):
            old = getattr(self, name)
            arr = np.zeros((cap, *old.shape[1:]), old.dtype)
            arr[: self._n] = old[: self._n]
            setattr(self, name, arr)

    def _extend(self, rows: I64, now: int, xy: F64, dt_s: F64) -> None:
        """Live rows ``rows`` matched detections at ``xy``: :meth:`_Tracks.extend`, except
        that a zero time step keeps the velocity."""
        cfg = self.config
        old_v = self._v[rows]
        moved = dt_s > 0
        step = (xy - self._xy[rows]) / np.where(moved, dt_s, 1.0)[:, None]
        if not moved.all():
            step[~moved] = old_v[~moved]
        a = np.where(self._count[rows] == 1, 1.0, cfg.velocity_smoothing)[:, None]
        v = old_v + a * (step - old_v)
        speed2 = np.einsum("ij,ij->i", v, v)
        too_fast = speed2 > cfg.max_speed * cfg.max_speed
        if too_fast.any():  # a person does not outrun max_speed
            v[too_fast] *= (cfg.max_speed / np.sqrt(speed2[too_fast]))[:, None]
        self._v[rows], self._xy[rows], self._t[rows] = v, xy, now
        self._count[rows] += 1



def _stream(seed: int, frames: int, crowd: float) -> tuple[I64, F64]:
    """Random detections: ``frames`` messages of 0-12 people around a few hot spots (many
    gated pairs per track), stamps 0-1.5 s apart with repeats and backward jitter, a few
    NaN and far-out positions."""
    rng = np.random.default_rng(seed)
    gaps = rng.choice([0, 50_000_000, 400_000_000, 1_000_000_000, 2_500_000_000], frames)
    stamps = T0 + np.cumsum(gaps) - rng.choice([0, 0, 0, 200_000_000], frames)
    sizes = rng.integers(0, 13, frames)
    t = np.repeat(stamps, sizes).astype(np.int64)
    spots = rng.uniform(-5, 5, (3, 2))
    xy = spots[rng.integers(0, 3, t.size)] + rng.normal(0, crowd, (t.size, 2))
    odd = rng.random(t.size)
    xy[odd < 0.01] = np.nan
    xy[(odd >= 0.01) & (odd < 0.015)] = 1e300
    return t, xy


def _link(cls: type[TrackLinker], t: I64, xy: F64, cuts: list[int], cfg: LinkerConfig) -> Any:
    linker = cls(cfg, capacity=4)
    cuts = [c % (len(t) + 1) for c in cuts]
    # chunks end between frames: a stamp split over two calls is no longer linked as the code
    # before issue 15 did (its second part may not join tracks that had their detection of it)
    cuts = [c for c in cuts if np.intersect1d(t[:c], t[c:]).size == 0]
    bounds = [0, *sorted(cuts), len(t)]
    ids = np.concatenate([linker.link(t[a:b], xy[a:b]) for a, b in pairwise(bounds)])
    n = len(linker)
    state = [arr[:n].tobytes() for arr in (linker._ids, linker._t, linker._xy, linker._v,
                                             linker._count)]
    return ids, state, linker.next_id


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    frames=st.integers(1, 120),
    crowd=st.sampled_from([0.05, 0.3, 1.0, 3.0]),
    cuts=st.lists(st.integers(0, 10_000), max_size=4),
    smoothing=st.sampled_from([1.0, 0.5, 0.2]),
)
def test_linker_equals_the_per_frame_code_it_replaced(
    seed: int, frames: int, crowd: float, cuts: list[int], smoothing: float
) -> None:
    t, xy = _stream(seed, frames, crowd)
    cfg = LinkerConfig(velocity_smoothing=smoothing, max_speed=1.5)
    ids, state, next_id = _link(TrackLinker, t, xy, cuts, cfg)
    ids0, state0, next_id0 = _link(_LinkerBefore, t, xy, cuts, cfg)
    assert np.array_equal(ids, ids0)
    assert state == state0
    assert next_id == next_id0


def test_crowded_frames_take_the_shortcuts(monkeypatch: pytest.MonkeyPatch) -> None:
    t, xy = _stream(7, 200, 0.3)
    calls = {"errstate": 0, "ix_": 0}
    errstate, ix_ = np.errstate, np.ix_

    def counted_errstate(**kw: Any) -> Any:
        calls["errstate"] += 1
        return errstate(**kw)

    def counted_ix(*args: npt.ArrayLike) -> Any:
        calls["ix_"] += 1
        return ix_(*args)

    monkeypatch.setattr(tracking.np, "errstate", counted_errstate)
    monkeypatch.setattr(tracking.np, "ix_", counted_ix)
    linker = TrackLinker()
    ids = linker.link(t, xy)
    assert len(_frames(t)[0]) > 100
    assert linker.next_id < np.count_nonzero(ids >= 0)  # tracks of several detections
    assert calls == {"errstate": 1, "ix_": 0}
