"""Two array helpers of :class:`aion_cli.engine.heading.HeadingEstimator`'s vectorised
differencing: the bounding-box test that passes over a standing person's rows at once
(:func:`_inside_circle`) and the reset chains followed by pointer doubling (:func:`_chains`).
Pure numpy; moved out of ``engine/heading.py`` verbatim to keep that file under 500 lines."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, I64

#: Levels of the sparse min/max table of :func:`_inside_circle`: ranges up to 2**(L+1) nodes.
_BOX_LEVELS = 8


def _inside_circle(
    x: F64, y: F64, nodes: I64, a: I64, b: I64, radius: float
) -> npt.NDArray[np.bool_]:
    """Whether every node ``a .. b - 1`` is certainly closer than ``radius`` to its node of
    ``nodes``: the bounding box of the range (a sparse table of min/max, levels up to
    :data:`_BOX_LEVELS`; longer ranges are not decided) has its farthest corner inside the
    circle, with a margin far above rounding (so a True here never contradicts the exact
    per-node test; NaN positions, which never reset by distance, only make it False)."""
    inside = np.zeros(len(nodes), dtype=bool)
    w = b - a
    level = np.minimum(np.frexp(w.astype(np.float64))[1] - 1, _BOX_LEVELS)
    ok = w <= 2 * (1 << level)
    top = int(level[ok].max(initial=-1))
    if top < 0:
        return inside
    tables = [(x, x, y, y)]
    for k in range(top):
        h = 1 << k
        x_lo, x_hi, y_lo, y_hi = tables[-1]
        tables.append((
            np.fmin(x_lo[:-h], x_lo[h:]), np.fmax(x_hi[:-h], x_hi[h:]),
            np.fmin(y_lo[:-h], y_lo[h:]), np.fmax(y_hi[:-h], y_hi[h:]),
        ))
    for k in range(top + 1):
        sel = np.flatnonzero(ok & (level == k))
        if sel.size == 0:
            continue
        x_lo, x_hi, y_lo, y_hi = tables[k]
        sa, sb = a[sel], b[sel] - (1 << k)
        xi, yi = x[nodes[sel]], y[nodes[sel]]
        rx = np.fmax(np.abs(np.fmin(x_lo[sa], x_lo[sb]) - xi),
                     np.abs(np.fmax(x_hi[sa], x_hi[sb]) - xi))
        ry = np.fmax(np.abs(np.fmin(y_lo[sa], y_lo[sb]) - yi),
                     np.abs(np.fmax(y_hi[sa], y_hi[sb]) - yi))
        inside[sel] = np.hypot(rx, ry) < radius * (1.0 - 1e-9)
    return inside


def _chains(nxt: I64, roots: I64) -> npt.NDArray[np.bool_]:
    """Nodes reachable from ``roots`` by ``nxt`` (a node's next reset; ``len(nxt) - 1`` is the
    end, mapped to itself).

    Runs of nodes that each reset at the very next node (a walker's) are taken whole: a chain
    that enters a run at ``e`` covers it to its exit (the first node whose next reset is not
    its neighbour) and continues at that exit's next reset. Only the entries (roots and
    targets of longer jumps) are chained, by pointer doubling: after step ``k`` the first
    ``2**k`` entries of every chain are marked and the jumps leap ``2**k`` entries, so a chain
    of ``L`` entries takes about ``log2 L`` steps; the runs from the reached entries are then
    marked with one cumulative sum."""
    n = len(nxt) - 1
    index = np.arange(n)
    step = nxt[:n]
    unit = step == index + 1
    unit[-1:] = False  # the last node's next is the end, not a neighbour
    exits = np.minimum.accumulate(np.where(unit, n, index)[::-1])[::-1]
    jumps = step[~unit]
    entry = np.zeros(n + 1, dtype=bool)
    entry[roots] = True
    entry[jumps] = True
    entry[n] = False
    entries = np.flatnonzero(entry)
    compact = np.full(n + 1, len(entries), np.int64)
    compact[entries] = np.arange(len(entries))
    m = len(entries)
    jump = np.append(compact[step[exits[entries]]], m)
    reach = np.zeros(m + 1, dtype=bool)
    reach[compact[roots]] = True
    while True:
        target = jump[np.flatnonzero(reach[:m])]
        target = target[~reach[target]]
        if target.size == 0 or bool((target == m).all()):
            break
        reach[target] = True
        reach[m] = False
        jump = jump[jump]
    first = entries[reach[:m]]
    marks = np.zeros(n + 1, np.int64)
    marks[first] += 1
    marks[exits[first] + 1] -= 1
    return np.cumsum(marks[:n]) > 0
