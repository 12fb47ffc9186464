"""Row sums of narrow float arrays, equal to the bit to ``a.sum(axis=1)`` and about four times
faster.

The temporal model sums rows of a few columns millions of times a day of scoring (a pair's B
direction bins, an entry's V value bins). numpy reduces each short row in its own inner loop,
whose set-up costs more than the additions; adding whole columns instead runs one long loop
per column. To keep every result unchanged, the columns are added in the order numpy's
pairwise summation adds a row of up to 128 elements (``pairwise_sum`` in numpy's
``loops_utils``): below 8 elements one after the other from zero; from 8 on, eight running
sums over the elements ``j, j + 8, ...``, combined as ``((s0 + s1) + (s2 + s3)) + ((s4 + s5)
+ (s6 + s7))``, then the remainder one by one. Wider arrays, other dtypes and other axes go
to numpy itself. Tested bit for bit against ``sum(axis=1)`` (``tests/engine/test_row_sums``).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64

_UNROLL = 8
_BLOCK = 128  # numpy sums longer rows recursively in halves: those go to numpy


def row_sums(a: npt.NDArray[np.float64], keepdims: bool = False) -> F64:
    """``a.sum(axis=1, keepdims=keepdims)`` of a 2-D array (see the module docstring)."""
    if a.ndim != 2 or a.dtype != np.float64 or not 2 <= a.shape[1] <= _BLOCK:
        out: F64 = a.sum(axis=1, keepdims=keepdims)
        return out
    n = a.shape[1]
    if n < _UNROLL:
        total = a[:, 0] + a[:, 1]
        for j in range(2, n):
            total += a[:, j]
    else:
        if n >= 2 * _UNROLL:  # the first two blocks of eight, into fresh arrays
            s = [a[:, j] + a[:, j + _UNROLL] for j in range(_UNROLL)]
            i = 2 * _UNROLL
        else:  # one block: read only (the loop below does not run)
            s = [a[:, j] for j in range(_UNROLL)]
            i = _UNROLL
        while i + _UNROLL <= n:
            for j in range(_UNROLL):
                s[j] += a[:, i + j]
            i += _UNROLL
        total = s[0] + s[1]
        total += s[2] + s[3]  # (s0 + s1) + (s2 + s3): the right side is computed first
        right = s[4] + s[5]
        right += s[6] + s[7]
        total += right
        for j in range(i, n):
            total += a[:, j]
    total += 0.0  # numpy's sums start from +0: a row of -0.0 sums to +0.0
    return total[:, None] if keepdims else total
