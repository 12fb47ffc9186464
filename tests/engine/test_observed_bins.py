"""``family_summary``'s ``observed_bins``: the profile bins (hour of day × kind of day) in
which a fixed sensor observed anything, checked against the bins of the windows themselves,
whatever part of them is absorbed, pending or still open; and ``temporal.query_state.observed_bins``
under it, which reads only the rows observed on their own."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.family_summary import family_summary
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.calendar import Calendar
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.query_state import observed_bins
from tests.engine.engine_builders import DAY_NS, T0, detections

W = 600 * 10**9


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.integers(0, 21 * 144), min_size=1, max_size=40, unique=True),
    st.sampled_from(["UTC", "Asia/Tokyo", "America/New_York"]),
    st.sampled_from(["day", "day_weekend", "week"]),
)
def test_the_bins_are_those_of_the_windows_observed(
    offsets: list[int], zone: str, profile: str
) -> None:
    """Random fixed-sensor windows over three weeks, one detection in the last: the bins the
    summary lists are the calendar's bins of those windows' centres, no more, no fewer."""
    config = ModelConfig(timezone=zone, profile=profile)
    mapper = Mapper(config)
    start = T0 // W
    windows = np.sort(np.asarray(offsets, np.int64)) + start
    mapper.set_fixed_windows(windows)
    last = int(windows[-1]) * W
    mapper.add_detections(detections(last + 10**9, [[0.2, 0.2, 0.0]]))
    mapper.advance(last + W // 2)  # the last window stays open
    got = family_summary(mapper.state)["observed_bins"]
    centres = windows * W + W // 2
    expected = np.unique(Calendar(zone, profile).profile_bin(centres))
    assert got == expected.tolist()
    assert (windows[-1] - windows[0]) * W < 22 * DAY_NS


def test_rows_never_observed_on_their_own_are_not_read() -> None:
    """``temporal.query_state.observed_bins`` reads the profiles of the rows with windows of their
    own (n > 0) only: a fixed sensor's map of 10^5 cells has an all-zero profile of 48 bins
    per row, which gathering cost a third of ``aion predict --top 10``. Rows 0 and 2 saw bins
    3 and 5; row 1 (n = 0) holds ones in every bin, which it cannot hold in a map (n is the
    sum of its bins) and which must not count; row 3 is not among the rows asked."""
    params = TemporalParams(ModelConfig())
    bins = params.n_profile
    state = TemporalState.empty(4, values=2, periods=params.n_periods, bins=bins,
                                flow_families=len(params.flow),
                                dir_families=len(params.direction))
    state.obs.n[[0, 2, 3]] = [2.0, 0.5, 1.0]
    state.obs.profile[0, 3] = 2.0
    state.obs.profile[2, 5] = 0.5
    state.obs.profile[1] = 1.0
    state.obs.profile[3, 7] = 1.0
    state.glob.profile[0, 9] = 4.0
    got = observed_bins(params, state, np.array([0, 1, 2]), [], 0)
    assert got.tolist() == [3, 5, 9]
    assert observed_bins(params, state, np.array([1]), [], 0).tolist() == [9]
    assert observed_bins(params, state, np.array([], np.int64), [], 0).tolist() == [9]


def test_a_patrolled_map_has_the_bins_of_every_row_profile() -> None:
    """On a map a robot built (rows with windows of their own), the bins are those of any
    row's profile or the map's (the sums the map stores), as gathering every row gave."""
    mapper = Mapper(ModelConfig())
    for day in range(3):
        t = T0 + day * DAY_NS + np.arange(0, 6 * 3600, 900) * 10**9
        for k, ti in enumerate(t.tolist()):
            mapper.add_detections(detections(int(ti), [[0.2 + k % 5, 0.2 + day, 0.0]]))
    mapper.advance(T0 + 3 * DAY_NS)
    temporal = mapper.state.query_temporal()
    rows = mapper.state.entries.canonical_order()
    assert (temporal.obs.n[rows] > 0).any()
    every = (temporal.obs.profile[rows] > 0).any(axis=0) | (temporal.glob.profile[0] > 0)
    got = observed_bins(mapper.state.params, temporal, rows, [], 0)
    assert got.tolist() == np.flatnonzero(every).tolist()
    assert got.size > 0
