"""The heading sums that place a forecast's bins, picked for the rows described only
(issue 15: ``predict --top 10`` of a map of 10^5 entries places ten rows' bins, not every
entry's): each row's are its own where it has any, its pooling group's where it has none,
the map's where its group has none either, and none for a graph's place without an entry;
the same for any rows picked (``--top N`` describing its rows as the whole table does:
tests/cli/test_predict_rows.py)."""

from __future__ import annotations

import numpy as np

from aion_cli.engine.descriptors import PooledHeadings


def _placed_by_hand(own_c: np.ndarray, own_s: np.ndarray, groups: np.ndarray, n_groups: int,
                    extra: int) -> tuple[np.ndarray, np.ndarray]:
    """The rule row by row and bin by bin, sums in row order (as the entries are listed)."""
    rows, bins = own_c.shape
    out_c, out_s = np.zeros((rows + extra, bins)), np.zeros((rows + extra, bins))
    for r in range(rows):
        for b in range(bins):
            if own_c[r, b] != 0 or own_s[r, b] != 0:
                out_c[r, b], out_s[r, b] = own_c[r, b], own_s[r, b]
                continue
            gc = gs = 0.0
            for q in range(rows):
                if groups[q] == groups[r]:
                    gc, gs = gc + own_c[q, b], gs + own_s[q, b]
            if gc != 0 or gs != 0:
                out_c[r, b], out_s[r, b] = gc, gs
                continue
            mc = ms = 0.0
            for q in range(rows):
                mc, ms = mc + own_c[q, b], ms + own_s[q, b]
            out_c[r, b], out_s[r, b] = mc, ms
    return out_c, out_s


def test_own_then_group_then_map_for_any_rows_picked() -> None:
    rng = np.random.default_rng(7)
    rows, bins, n_groups, extra = 60, 8, 5, 3
    own_c = rng.normal(size=(rows, bins))
    own_s = rng.normal(size=(rows, bins))
    groups = rng.integers(0, n_groups - 1, rows)  # the last group has no entry
    own_c[rng.random((rows, bins)) < 0.5] = 0.0
    own_s[own_c == 0] = 0.0  # half the bins without a heading
    own_c[groups == 2, 3] = own_s[groups == 2, 3] = 0.0  # a group without bin 3: the map's
    own_c[:, 5] = own_s[:, 5] = 0.0  # no entry has bin 5: no direction anywhere
    want_c, want_s = _placed_by_hand(own_c, own_s, groups, n_groups, extra)
    placed = PooledHeadings.of(own_c, own_s, groups, n_groups, extra)
    assert len(placed) == rows + extra
    every_c, every_s = placed.rows()
    # sums in the rows' order: the same floats as by hand
    assert np.array_equal(every_c, want_c)
    assert np.array_equal(every_s, want_s)
    assert (want_c[:rows][groups == 2, 3] != 0).all()  # the map's fill is exercised
    assert (want_c[:rows, 5] == 0).all()
    assert (want_c[rows:] == 0).all()
    for pick in ([0], [rows + 1, 4, 4, 59], rng.permutation(rows + extra)[:17], []):
        c, s = placed.rows(np.asarray(pick, dtype=np.int64))
        assert np.array_equal(c, want_c[pick])
        assert np.array_equal(s, want_s[pick])
