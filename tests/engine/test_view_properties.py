"""Properties of the views a query of a map forecasts with (stop 69):

* ``calendar_view.pooled_view``: a ``week`` map whose evidence does not ask for the week reads
  its sums pooled into weekday and weekend hours, each time's week bin landing on the bin the
  ``day_weekend`` calendar gives the same time (any time, zone and bin width), every
  profile-binned total kept, the state itself untouched; a map asking for the week is read
  as it is;
* ``view_priors``: computing the priors a map stores (pending day and open window absorbed in
  place, then taken out) leaves every accumulator bit-identical, and they are exactly what a
  query of the written state estimates without them."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.state import MapState
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.calendar import Calendar
from aion_cli.engine.temporal.calendar_view import forecast_calendar, pooled_view
from aion_cli.engine.temporal.model import empty_state
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pool_priors import MEMBER, PoolPriors
from aion_cli.engine.temporal.shape_prior import pool_week, pooled_week_bins
from aion_cli.engine.temporal.week_evidence import MIN_DAYS, week_bins
from aion_cli.engine.view_priors import view_priors
from aion_cli.engine.windows import EPOCH_NS
from tests.engine.engine_builders import (
    T0_DAY_END,
    S,
    assert_temporal_unchanged,
    feed_detect,
    graph,
    start_fed_mapper,
)
from tests.engine.test_ownership import POOL

ZONES = ["UTC", "Europe/Berlin", "America/New_York", "Asia/Kolkata", "Pacific/Chatham",
         "Australia/Lord_Howe", "+05:45"]  # fmt: skip
BIN_S = [3600.0, 1800.0, 7200.0, 900.0, 10800.0]
SECOND = 10**9


@given(
    st.integers(-2_200_000_000, 9_000_000_000),  # 1900 .. 2255, in seconds
    st.sampled_from(ZONES),
    st.sampled_from(BIN_S),
)
@settings(max_examples=400, deadline=None)
def test_every_week_bin_pools_onto_the_day_weekend_bin_of_the_same_time(
    seconds: int, zone: str, bin_s: float
) -> None:
    """The week calendar's bin of a time, pooled (``pooled_week_bins``, and ``pool_week`` of
    a sum held in that bin alone), is the ``day_weekend`` calendar's bin of that time; and
    ``week_bins`` (the week sums' hour of the week of a slot of any profile) gives back the
    week calendar's bin from the ``day_weekend`` bin."""
    t = np.array([seconds * SECOND + SECOND // 2], np.int64)  # inside a second: no rounding edge
    week = Calendar(zone, "week", bin_s)
    day_weekend = Calendar(zone, "day_weekend", bin_s)
    per_day = week.bins_per_day
    wb, db = week.profile_bin(t), day_weekend.profile_bin(t)
    assert pooled_week_bins(wb, per_day).tolist() == db.tolist()
    one = np.zeros(7 * per_day, np.int64)
    one[wb[0]] = 1
    pooled = pool_week(one, per_day)
    assert pooled.dtype == np.int64
    assert pooled.sum() == 1
    assert int(pooled[db[0]]) == 1
    utc_s = (t - np.int64(EPOCH_NS)).astype(np.float64) / 1e9
    assert week_bins(day_weekend, db, utc_s).tolist() == wb.tolist()


def _week_state(
    rng: np.random.Generator, params: TemporalParams, rows: int, asks_for_week: bool
) -> TemporalState:
    """A temporal state of a ``week`` map with whole counts and windows in every
    profile-binned sum, and week sums that ask for the week or not."""
    t = empty_state(params, rows)
    t.cnt_profile[...] = rng.integers(0, 5, t.cnt_profile.shape)
    t.obs.profile[...] = rng.integers(0, 9, t.obs.profile.shape)
    t.glob.profile[...] = rng.integers(0, 9, t.glob.profile.shape)
    per_day = params.calendar.bins_per_day
    level = rng.integers(0, 4, (4, 2 * params.n_profile)).astype(np.float64)
    t.day_level = level
    sums = np.zeros((4, 7 * per_day))
    sums[0] = MIN_DAYS if asks_for_week else rng.integers(0, MIN_DAYS, 7 * per_day)
    sums[1:3] = rng.integers(0, 50, (2, 7 * per_day))
    sums[3] = rng.normal(0.0, 1.0, 7 * per_day) + (10.0 if asks_for_week else 0.0)
    t.week_sums = sums
    return t


@given(st.integers(0, 2**32 - 1), st.integers(1, 6), st.sampled_from([3600.0, 7200.0]),
       st.booleans())  # fmt: skip
@settings(max_examples=120, deadline=None)
def test_the_pooled_view_keeps_every_total_and_leaves_the_state(
    seed: int, rows: int, bin_s: float, asks_for_week: bool
) -> None:
    """Not asking for the week: the view's profile-binned sums are the state's pooled
    (weekday bins summed over Monday to Friday at their hour, weekend bins over Saturday and
    Sunday), each entry's and block's total over its bins unchanged, the other arrays the
    state's own, its parameters the ``day_weekend`` profile's; the state's arrays hold the
    same bits as before. Asking for the week: the very objects given."""
    params = TemporalParams(ModelConfig(profile="week", profile_bin_s=bin_s))
    rng = np.random.default_rng(seed)
    t = _week_state(rng, params, rows, asks_for_week)
    before = t.copy()
    got_params, view = pooled_view(params, t)
    per_day = params.calendar.bins_per_day
    if forecast_calendar(params, t) == "week":
        event("the week asked for")
        assert got_params is params
        assert view is t
        return
    assert not asks_for_week
    assert got_params.calendar.profile == "day_weekend"
    assert got_params.calendar.bins_per_day == per_day
    assert got_params.n_profile == 2 * per_day
    for name, old, new in (
        ("cnt_profile", t.cnt_profile, view.cnt_profile),
        ("obs", t.obs.profile, view.obs.profile),
        ("glob", t.glob.profile, view.glob.profile),
    ):
        days = old.reshape(*old.shape[:-1], 7, per_day)
        expected = np.concatenate([days[..., :5, :].sum(-2), days[..., 5:, :].sum(-2)], -1)
        np.testing.assert_array_equal(new, expected, err_msg=name)
        np.testing.assert_array_equal(new.sum(-1), old.sum(-1), err_msg=name)
    level = t.day_level
    assert view.day_level.shape == (4, 4 * per_day)
    assert view.day_level.sum() == level.sum()
    assert view.cnt_fourier is t.cnt_fourier
    assert view.week_sums is t.week_sums
    after = t.copy()
    for name in ("cnt_profile", "cnt_fourier", "day_level", "week_sums", "window_chi2"):
        assert getattr(after, name).tobytes() == getattr(before, name).tobytes(), name
    for block in ("obs", "glob"):
        assert getattr(after, block).profile.tobytes() == getattr(before, block).profile.tobytes()


# -- view_priors ------------------------------------------------------------------------------
op = st.one_of(
    st.tuples(st.just("detect"), st.integers(1, 30), st.integers(0, 10**6)),
    st.tuples(st.just("graph"), st.integers(-1, 4), st.sampled_from([0.0, 0.1, 2.0])),
    st.tuples(st.just("wait"), st.integers(1, 2000), st.just(0.0)),
)


def _fed(ops: list[tuple[str, int, float]], robot: bool, week: bool) -> MapState:
    profile = "week" if week else "day_weekend"
    cfg = ModelConfig(stability_s=10.0, window_s=60.0, cell_size=0.5, bind_radius=1.0,
                      profile=profile)  # fmt: skip
    start = T0_DAY_END - 300 * S
    m = start_fed_mapper(cfg, start, robot, 30_000, 10**6, POOL)
    present = np.ones(len(POOL), bool)
    t = start
    for kind, a, b in ops:
        t += 7 * S
        if kind == "detect":
            feed_detect(m, t, int(a), b)
        elif kind == "graph":
            if int(a) >= 0:
                present[int(a)] = ~present[int(a)]
            idx = np.flatnonzero(present)
            m.add_graph(graph(t, idx.tolist(), POOL[idx] + float(b)))
        else:
            t += int(a) * S
            m.advance(t)
    return m.state


@given(st.lists(op, min_size=1, max_size=12), st.booleans(), st.booleans())
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_view_priors_leave_the_state_and_are_what_a_query_estimates(
    ops: list[tuple[str, int, float]], robot: bool, week: bool
) -> None:
    """Any state a build reaches (a robot's or a fixed sensor's windows, a pending day or not,
    an open window or not; a ``week`` map or not): ``view_priors`` leaves every accumulator,
    the global and observation blocks, the map-wide sums, the generation and the high-water
    mark as they were, bit for bit; it gives the same twice; and a query of the state
    written without them (read back as a query reads a file) estimates exactly them."""
    state = _fed(ops, robot, week)
    assume(state.entries.canonical_order().size > 0)
    t = state.temporal
    before = t.copy()
    generation, high_water = t.generation, t.high_water
    priors = view_priors(state)
    assert_temporal_unchanged(before, t.copy())
    assert (t.generation, t.high_water) == (generation, high_water)
    assert view_priors(state) == priors
    arrays, meta = state.to_arrays()
    assert PoolPriors.from_arrays(arrays) == priors
    bare = {k: v for k, v in arrays.items() if k != MEMBER}
    query = MapState.from_arrays(bare, meta, writable=False, copy=True, forecast_only=True)
    rows, predictor = query.predictor()
    pool = predictor.forecaster.pool
    kappa_g = None if pool.shift is None else pool.shift.kappa
    estimated = PoolPriors(pool.kappa, pool.kappa_t, kappa_g, rows.size, len(pool.histogram))
    assert estimated == priors
    if state.pending:
        event("a pending day")
    if state.open_window is not None:
        event("an open window")
    if t.glob.n[0] > 0 or t.obs.n.sum() > 0:
        event("windows absorbed")
