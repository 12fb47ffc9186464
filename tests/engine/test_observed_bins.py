"""``family_summary``'s ``observed_bins``: the profile bins (hour of day × kind of day) in
which a fixed sensor observed anything, checked against the bins of the windows themselves,
whatever part of them is absorbed, pending or still open."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.family_summary import family_summary
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.temporal.calendar import Calendar
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
