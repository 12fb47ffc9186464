"""A day's FreMEn sums over a fixed sensor's slots, block by block of entries (issue 15).

Closing a day under a fixed sensor evaluates Σ_s max(λ_m(t_s), floor) for every entry, every
slot s of the day and every order m where the floor may bite (``scoring._per_window_sums``:
3,684 entries × 144 slots × 4 orders a day in the 20-day bench build). :class:`FixedSlots`
evaluates one block of entries at a time as an (order × slot × entry) array, every order in
one numpy pass per step: the tables of 2 Re e^{−iωt} and 2 Im e^{−iωt} gathered per order
into buffers reused from block to block, the orders' running sum over whole contiguous
planes. Every value is the same floating-point operation as the pair-by-pair sums (tested
bit for bit against them and against the per-order blocks, tests/engine).
"""

from __future__ import annotations

import numpy as np

from aion_cli.engine.types import F64, I64


class FixedSlots:
    """The fixed-sensor slots' phasors and the entries' FreMEn parts, ready for blocks."""

    def __init__(
        self, rot_slots: np.ndarray, share: F64 | None, idx: I64, coef: np.ndarray, rate: F64
    ) -> None:
        """``rot_slots``: e^{−iωt} of the slots, complex[S, K]; ``share``: the part of each
        slot's window the logs recorded (None: whole); ``idx``/``coef`` int64/complex[E, M]:
        each entry's periods and coefficients γ; ``rate``: its static rate μ, float64[E]."""
        # 2 Re(γ z) = Re γ · 2 Re z − Im γ · 2 Im z (z = e^{−iωt}): real arithmetic only
        self.cos2 = np.ascontiguousarray(2.0 * rot_slots.real)
        self.sin2 = np.ascontiguousarray(2.0 * rot_slots.imag)
        self.share = None if share is None else share[:, None]
        self.idx = np.ascontiguousarray(idx.T)  # (M, E): a block's columns, orders-major
        self.coef_re = np.ascontiguousarray(coef.real.T)[:, None, :]  # (M, 1, E)
        self.coef_im = np.ascontiguousarray(coef.imag.T)[:, None, :]
        self.rate = rate
        self._room = np.zeros((2, 0))

    def sums(self, i0: int, i1: int, before: int, upto: int, floor: float) -> F64:
        """Σ over the slots of max(μ + Σ_{j≤m} 2 Re(γ_j z), floor) (times the slot's share)
        for entries ``i0 .. i1`` and every order m, float64[M, i1 − i0]. The first entry's
        first ``before`` slots and the last entry's slots from ``upto`` on count 0.0 (pairs of
        another chunk; adding 0.0 leaves a sum of positive terms unchanged).

        The block is held order by order, (order × slot × entry): the running sum over the
        orders adds whole contiguous (slot × entry) planes (an order's plane in a (slot ×
        order × entry) block is strided, and those additions were this block's slowest step),
        and the slots are added in order (a reduction over the middle axis of a C-ordered
        array, each order's rows one after the other, as bincount's running sums add them).
        The orders' running sum starts at the first order's term where cumsum starts at 0.0 +
        it: only the sign of a zero can differ, and the clamp at a floor > 0 removes it."""
        m = self.idx.shape[0]
        lam = self._gathered(0, self.cos2, i0, i1)
        lam *= self.coef_re[:, :, i0:i1]
        minus = self._gathered(1, self.sin2, i0, i1)
        minus *= self.coef_im[:, :, i0:i1]
        lam -= minus
        for j in range(1, m):
            lam[j] += lam[j - 1]
        lam += self.rate[i0:i1]
        np.maximum(lam, floor, out=lam)
        if self.share is not None:  # expected detections: λ times the share
            lam *= self.share
        lam[:, :before, 0] = 0.0
        lam[:, upto:, -1] = 0.0
        return sum_slots_in_order(lam)

    def _gathered(self, slot: int, table: F64, i0: int, i1: int) -> F64:
        """``table`` (C-ordered, float64[S, K]) at each order's periods of entries ``i0 ..
        i1``, float64[M, S, i1 − i0], in buffer ``slot``, which grows as needed and is reused
        by the next block (no fresh pages per block)."""
        m, s, n = self.idx.shape[0], table.shape[0], i1 - i0
        size = m * s * n
        if self._room.shape[1] < size:
            self._room = np.empty((2, size))
        out = self._room[slot, :size].reshape(m, s, n)
        for j in range(m):  # indices are valid: "clip" writes into ``out`` without a copy
            np.take(table, self.idx[j, i0:i1], axis=1, out=out[j], mode="clip")
        return out


def sum_slots_in_order(values: F64) -> F64:
    """Sums over the middle axis of ``values`` (M, S, n), float64[M, n], adding the slots
    one after the other, as running sums do: numpy reduces over a middle axis of a C-ordered
    array that way (each plane's rows added in turn), except for a single entry, whose
    slots it would reduce as a contiguous run (then an accumulation along them, which is
    sequential; tested against the pair-by-pair sums bit for bit)."""
    if values.shape[2] == 1:
        out: F64 = np.add.accumulate(values[:, :, 0], axis=1)[:, -1:]
        return out
    summed: F64 = np.add.reduce(values, axis=1)
    return summed


def sum_in_order(values: F64) -> F64:
    """Column sums of ``values`` (S, n) adding the rows one after the other, as running sums
    do: numpy reduces over the outer axis of a 2-D array that way (a sum along a contiguous
    row may be pairwise), except for a single column, which it reduces as a contiguous run
    (tested against the pair-by-pair sums bit for bit)."""
    if values.shape[1] == 1:
        out: F64 = np.add.accumulate(values[:, 0])[-1:]
        return out
    summed: F64 = np.add.reduce(values, axis=0)
    return summed
