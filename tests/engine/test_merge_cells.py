"""``aion merge``'s fold of maps without nodes (fixed sensors, released nodes) is built in
the earlier map's storage (:mod:`aion_cli.engine.merge_cells`): each step costs the map
added, not the result so far. The result must be the pairwise fold's (built in the later
map, copying the result so far at every step), in areas of their own and in one shared area,
with pending days and open windows."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.mapper import Mapper
from aion_cli.engine.merge import merge_maps
from aion_cli.engine.rebind import release_all
from aion_cli.engine.state import MapState
from tests.engine.engine_builders import T0, S, detections
from tests.engine.state_logs import (
    CFG,
    DAY,
    W,
    assert_same_state,
    fixed_sensor_log,
    fold_in_earlier_map,
    run_steps,
)

HOUR = 3600 * S
#: members that are sums of one value per map (or min/max), the same to the bit
_EXACT = (
    "entry_key", "entry_kind", "entry_counts", "entry_nodir", "entry_window_counts",
    "entry_speed_n", "entry_speed_sum", "entry_heading_cos", "entry_heading_sin",
    "temporal_glob_n", "temporal_glob_profile", "temporal_obs_n", "temporal_obs_profile",
    "temporal_obs_first", "temporal_obs_last", "temporal_cnt_profile", "temporal_cnt_fourier",
    "pending_windows", "pending_fixed", "pending_obs_entry", "pending_cnt_entry",
    "pending_cnt_slot", "pending_cnt_values",
)


def _fixed_map(k: int, shared: bool, windows: int) -> MapState:
    """Map ``k``: a fixed sensor from 20:00 on day 2k for ``windows`` windows (over
    midnight: a scored day and a pending one), people at spots of their own area (50 m
    apart per map) or of one area, and a last detection left in the open window."""
    rng = np.random.default_rng(k)
    start = T0 + 2 * k * DAY + 20 * HOUR
    m = Mapper(CFG)
    m.set_fixed_sensor(start, start + windows * W)
    x0 = 0.0 if shared else 50.0 * k
    spots = np.c_[x0 + rng.uniform(0, 6, (12, 2)), np.zeros(12)]
    for w in range(windows):
        n = int(rng.integers(3, 30))
        t = start + w * W + np.sort(rng.integers(0, W, n))
        heading = np.where(rng.random(n) < 0.1, np.nan, rng.uniform(-np.pi, np.pi, n))
        m.add_detections(detections(t, spots[rng.integers(0, 12, n)], heading,
                                    rng.uniform(0.2, 2, n)))
    m.advance(start + windows * W - S)  # the last window stays open
    return m.state


def _released_map(k: int, windows: int) -> MapState:
    """A map of a graph's places whose nodes are released to cells (``--lineage
    different``), from 22:00 on day 2k."""
    start = T0 + 2 * k * DAY + 22 * HOUR
    state = run_steps(fixed_sensor_log(start, seed=k, windows=windows)).state
    assert release_all(state) > 0
    return state


#: the fixed-sensor windows of each map of each kind
WINDOWS = {"released": (18, 30, 8, 20), "disjoint": (40, 30, 24, 50, 20)}
WINDOWS["shared"] = WINDOWS["disjoint"]


def _maps(kind: str) -> list[MapState]:
    if kind == "released":
        return [_released_map(0, 18), _fixed_map(1, False, 30), _released_map(2, 8),
                _fixed_map(3, False, 20)]
    # a large first map, then smaller and larger ones: both kinds of steps
    return [_fixed_map(k, kind == "shared", w) for k, w in enumerate(WINDOWS[kind])]


@pytest.mark.parametrize("kind", ["disjoint", "shared", "released"])
def test_the_fold_in_the_earlier_map_is_the_pairwise_fold(kind: str) -> None:
    fold = fold_in_earlier_map(lambda: _maps(kind), _EXACT)
    # what each map saw adds up: every entry observed over every map's fixed windows but
    # the last map's last (still open), every detection counted once
    rows = fold.entries.live_rows()
    windows = np.full(rows.size, sum(WINDOWS[kind]) - 1)
    np.testing.assert_array_equal(fold.windows_observed(rows), windows)
    assert fold.accepted == sum(s.accepted for s in _maps(kind))
    # the key -> row index kept up as cells were added is the one rebuilt from the cells
    kept = fold.routes
    fold.rebuild_routes()
    np.testing.assert_array_equal(kept.keys, fold.routes.keys)
    np.testing.assert_array_equal(kept.rows, fold.routes.rows)
    assert fold.open_window == _maps(kind)[-1].open_window


def test_maps_with_nodes_merge_in_the_earlier_map_by_rows() -> None:
    """Nodes (binds, redirects, timers) keep the cell path out: the merge of the touched rows
    is built in the later map and put into the earlier one (``engine/merge_rows.py``)."""
    early = run_steps(fixed_sensor_log(T0, seed=1, windows=12)).state
    late = run_steps(fixed_sensor_log(T0 + 2 * DAY, seed=2, windows=3)).state
    assert early.nodes.ids.size
    assert early.entries.n >= late.entries.n  # the fold in the earlier map would be chosen
    copied = merge_maps(early, late)
    assert merge_maps(early, late, consume=True) is early
    assert_same_state(copied, early)
