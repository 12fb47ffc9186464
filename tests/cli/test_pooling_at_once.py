"""A query's pooling of a map read back (counts read narrow, as whole numbers) sums the
groups' counts per (value bin, hour) once over every entry and takes the groups' periodic
sums and directed counts from them (issue 15), instead of block by block: the same pooled
statistics to the bit as the block-by-block sums, here on the bundled sample's map pooled in
blocks of 16 entries."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.temporal import pooling
from aion_cli.engine.temporal.calendar_view import pooled_view
from aion_cli.mapquery import load_map


def test_groups_summed_at_once_equal_block_by_block(sample_map: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(pooling, "_POOL_BLOCK", 16)
    asked: list[int] = []
    hourly = pooling.group_hourly

    def recorded(values: np.ndarray, rows: np.ndarray, groups: np.ndarray, n: int,
                 bins: int) -> np.ndarray:
        asked.append(bins)
        return hourly(values, rows, groups, n, bins)

    monkeypatch.setattr(pooling, "group_hourly", recorded)
    state = load_map(sample_map, forecast_only=True).state  # as aion predict reads it
    rows = state.entries.canonical_order()
    groups, n_groups = state.groups(rows)
    params, view = pooled_view(state.params, state.query_temporal())
    assert view.cnt_profile.dtype.kind == "u"
    assert rows.size > 16
    assert params.direction_enabled[1:].any()  # the groups' hourly counts are asked for
    counts, totals = pooling.entry_sums(view, rows)
    at_once = pooling.PoolStats.of(params, view, rows, groups, n_groups, counts, totals)
    assert asked == [params.values]  # every value bin at once: the new path
    blocks = pooling.PoolStats.of(params, view, rows, groups, n_groups)  # block by block
    assert asked == [params.values, params.bins]
    for name in ("shape", "histogram", "map_shape", "unseen"):
        assert np.array_equal(getattr(at_once, name), getattr(blocks, name)), name
    assert at_once.kappa == blocks.kappa
    assert at_once.kappa_t == blocks.kappa_t
    assert (at_once.shift is None) == (blocks.shift is None)
    if at_once.shift is not None and blocks.shift is not None:
        assert np.array_equal(at_once.shift.ratio, blocks.shift.ratio)
        assert at_once.shift.kappa == blocks.shift.kappa
