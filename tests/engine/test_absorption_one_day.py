"""A query's pending day and open window are one day of the map-wide sums
(``absorption.absorb_parts``): the level sample (``day_level``), the burstiness
(``window_chi2``) and the week sums add that day once, as closing the window and the day
will add it. Each part had added a day of its own (issue 12 of stop 70).

Known answers: a fixed sensor's hour of four windows of 1, 3, 5 and 7 detections, the last
one open, is one day of the cell: Σ T = 16 over 4 units, ρ = 4, the day-level sums
[1, ρ, ρ², ρ / b] = [1, 4, 16, 1], and Pearson's χ² of the four totals around ρ
(9 + 1 + 1 + 9) / 4 = 5 on 3 degrees of freedom (the parts alone: [1, 3, 9, 1] + [1, 7, 49, 7],
and χ² 8/3 on 2, the open window's lone slot compared with none). And a real map's query
(the market scenario, its Tuesday pending with its last window open) sees the map-wide sums
and forecasts that the same map, its open window closed into the pending day, sees."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal.absorption import absorb_parts, view_week_sums
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.model import empty_state
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from tests.engine.test_week_evidence import _build, _logs

S = 1_000_000_000
WINDOW_NS = 600 * S
MONDAY_8 = int(datetime(2026, 11, 2, 8, tzinfo=UTC).timestamp()) * S // WINDOW_NS


def _fixed(windows: list[int], counts: list[float], values: int) -> DayWindows:
    """A fixed sensor's windows, ``counts[i]`` detections of entry 0 in the last value bin."""
    cnt = np.zeros((len(counts), values))
    cnt[:, -1] = counts
    none = np.zeros(0, np.int64)
    return DayWindows(
        np.array(windows, np.int64), np.ones(len(windows), bool), none, none,
        np.zeros(len(counts), np.int64), np.arange(len(counts), dtype=np.int64), cnt,
    )  # fmt: skip


def _absorbed(parts: list[DayWindows]) -> tuple[TemporalParams, TemporalState]:
    params = TemporalParams.from_config(ModelConfig())
    state = empty_state(params, 1)
    absorb_parts(params, state, parts, WINDOW_NS)
    return params, state


def test_an_open_window_is_more_of_the_pending_days_hour() -> None:
    """Monday 08:00-08:40 UTC: three closed windows pending, the fourth open."""
    params = TemporalParams.from_config(ModelConfig())
    w = [MONDAY_8 + k for k in range(4)]
    pending, open_window = _fixed(w[:3], [1, 3, 5], params.values), _fixed(
        w[3:], [7], params.values
    )
    _, state = _absorbed([pending, open_window])
    cell = params.n_profile + int(params.calendar.profile_bin(np.array([w[0] * WINDOW_NS]))[0])
    np.testing.assert_allclose(state.day_level[:, cell], [1.0, 4.0, 16.0, 1.0])
    assert state.day_level[0].sum() == 1.0  # one day, one cell
    np.testing.assert_allclose(state.window_chi2, [5.0, 3.0])
    # the week sums: one day at the hour, its 16 detections over 4 units
    week = state.week_sums[:, state.week_sums[0] > 0]
    np.testing.assert_allclose(week[:3], [[1.0], [16.0], [4.0]])
    # as the day whose four windows were all closed (one part), to the bit
    _, whole = _absorbed([_fixed(w, [1, 3, 5, 7], params.values)])
    for name in ("day_level", "window_chi2", "week_sums"):
        np.testing.assert_array_equal(getattr(state, name), getattr(whole, name), name)
    assert np.array_equal(view_week_sums(params, _absorbed([])[1], [pending, open_window],
                                         WINDOW_NS), whole.week_sums)  # fmt: skip


def test_parts_of_two_days_stay_two_days() -> None:
    """A pending Monday and an open window on the Tuesday: two days (the window is not more
    of the Monday), each its own sample of the level."""
    params = TemporalParams.from_config(ModelConfig())
    monday = _fixed([MONDAY_8, MONDAY_8 + 1], [2, 4], params.values)
    tuesday = _fixed([MONDAY_8 + 144], [6], params.values)
    _, state = _absorbed([monday, tuesday])
    cell = state.day_level[0] > 0
    np.testing.assert_allclose(state.day_level[:, cell], [[2.0], [3.0 + 6.0], [9.0 + 36.0],
                                                          [1.5 + 6.0]])  # fmt: skip
    np.testing.assert_allclose(state.window_chi2, [2.0 / 3.0, 1.0])  # Monday's alone


def test_a_maps_query_sees_its_open_window_as_closed_into_the_pending_day(
    tmp_path: Path,
) -> None:
    """The market's Monday closed, its Tuesday pending with its last window open. Closing
    that window closes the Tuesday (scored, absorbed as one day); the map-wide sums and the
    forecasts of the query's view of two parts are the closed day's (before, the view of
    two parts had the Tuesday's open-window hour as a second day of the level sample and
    left its slot out of the burstiness: the flows of every entry differed, 0.49066 for
    0.49069 detections a window)."""
    from aion_cli.engine.closing import close_windows, open_window_record
    from aion_cli.mapquery import load_map
    from aion_cli.predictions import predicted_records

    site = _build(_logs("market", tmp_path, cuts=(2,))[:1], tmp_path / "two.aion")
    two_parts, one_part = load_map(site, writable=True), load_map(site, writable=True)
    state = one_part.state
    assert state.open_window is not None
    assert open_window_record(state) is not None
    day = state.pending.day
    assert day is not None
    close_windows(state, state.open_window + 1)  # the Tuesday's last window: its day closed
    assert not state.pending  # no part left
    assert open_window_record(state) is None
    views = two_parts.state.query_temporal(), state.query_temporal()
    for name in ("day_level", "window_chi2", "week_sums"):
        np.testing.assert_array_equal(getattr(views[0], name), getattr(views[1], name), name)
    assert views[0].day_level[0].max() == 2.0  # the Monday and the Tuesday
    t_ns = (day + 7) * 86400 * S + 10 * 3600 * S  # a week on, in the morning
    expected = predicted_records(one_part, t_ns)  # every entry's flow, its band, directions
    assert predicted_records(two_parts, t_ns) == expected
