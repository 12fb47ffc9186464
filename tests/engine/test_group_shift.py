"""An hour's direction histogram borrowed from the entry's group (``temporal.group_shift``).

One place split over several map cells: each cell alone holds too few directed detections an
hour to learn that the place is walked east in the morning and west in the evening, and at
stop 67 aion stayed 0.03 nats a held-out detection behind each place's own hour-of-day
histogram (docs/EVALUATION.md, "Generated multi-week rhythms"). The time-varying direction
families now shrink toward the entry's static histogram modulated by its group's hour."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from aion_cli.engine.temporal.group_shift import (
    GroupShift,
    group_hourly,
    hour_prior,
    hourly_priors,
)
from benchmarks.forecast_scenarios import SCENARIOS, run

B, H = 8, 24


def _hourly(flip: bool, groups: int, per_hour: int, rng: np.random.Generator) -> np.ndarray:
    """C[g, b, h] of ``groups`` groups, ``per_hour`` directed detections an hour in bins 0
    (east) and 4 (west): 0.8 east before 12:00 and 0.8 west after (``flip``), or half and
    half every hour."""
    share = np.where(np.arange(H) < 12, 0.8, 0.2) if flip else np.full(H, 0.5)
    east = rng.binomial(per_hour, np.tile(share, (groups, 1)))
    out = np.zeros((groups, B, H))
    out[:, 0], out[:, 4] = east, per_hour - east
    return out


def _histogram(hourly: np.ndarray) -> np.ndarray:
    total = hourly.sum(axis=2) + 0.5
    out: np.ndarray = total / total.sum(axis=1, keepdims=True)
    return out


def test_a_group_that_keeps_to_the_hour_shifts_a_sparse_entrys_prior() -> None:
    """Twelve groups, 40 directed detections an hour each, 0.8 / 0.2 east / west by the
    morning: the prior of an entry whose static histogram is half and half is near 0.8 east
    at 09:00 and near 0.2 at 18:00 (the group's κ_G shrinks the hour a little toward its
    half-and-half histogram), and an entry of a north-south corridor in the same group keeps
    its own directions (no east or west appears in its prior)."""
    hourly = _hourly(True, 12, 40, np.random.default_rng(3))
    histogram = _histogram(hourly)
    shift = GroupShift.of(hourly, histogram, None, H)
    assert shift is not None
    assert shift.telling.all()
    static = np.zeros((3, B))
    static[:2, [0, 4]] = 0.5
    static[2, [2, 6]] = 0.5  # north-south: east-west does not concern it
    prior = hour_prior(static.copy(), shift, np.zeros(3, np.int64), np.array([9, 18, 9]))
    assert 0.7 < prior[0, 0] < 0.85
    assert prior[0, 0] + prior[0, 4] == pytest.approx(1.0)
    assert 0.15 < prior[1, 0] < 0.3
    assert prior[2, [0, 4]].sum() == 0.0
    assert prior[2, [2, 6]] == pytest.approx(static[2, [2, 6]], abs=0.05)


def test_a_group_whose_directions_do_not_keep_to_the_hour_gives_back_the_static() -> None:
    """Half and half every hour: κ_G runs to the top of its range, there is no shift, and
    the prior is the static histogram itself."""
    hourly = _hourly(False, 12, 40, np.random.default_rng(4))
    assert GroupShift.of(hourly, _histogram(hourly), None, H) is None
    static = np.full((2, B), 1.0 / B)
    assert hour_prior(static, None, np.zeros(2, np.int64), np.array([9, 18])) is static


def test_group_sums_are_the_members_counts() -> None:
    """C[g, b, h] is the plain sum of each group's entries' directed counts (the last value
    bin, detections without a heading, left out), over more entries than one chunk and with
    counts held narrow (a query's), whose sums must not wrap."""
    rng = np.random.default_rng(5)
    values = rng.integers(0, 60_000, (300, B + 1, H)).astype(np.uint16)
    groups = rng.integers(0, 4, 300)
    rows = rng.permutation(300)[:290]  # some entries of the map, in any order
    out = group_hourly(values, rows, groups[:290], 5, B)
    for g in range(5):
        assert np.array_equal(out[g], values[rows[groups[:290] == g], :B].sum(axis=0))


def test_a_place_split_over_cells_learns_its_hours(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """Three places of 4-9 hash cells each (``weekly``), walked east before 13:00 and west
    after (0.8 of the walkers), two training weeks: each cell alone is too sparse to learn
    the hours (at stop 67 18 of 21 kept ``static``, 0.374 nats a held-out detection), but
    with its group's hour the held-out week's heading NLL is far below the static
    histogram's and within 0.015 of the same places held one cell each (``weekly-1cell``,
    where each entry sees its whole place), above the true directions' (the floor)."""
    split = replace(SCENARIOS["weekly"], train_days=14)
    whole = replace(SCENARIOS["weekly-1cell"], train_days=14)
    nll = run(split, tmp_path_factory.mktemp("cells"))["headings"]
    one = run(whole, tmp_path_factory.mktemp("one"))["headings"]
    assert nll["aion"] < nll["aion static"] - 0.1
    assert nll["aion"] <= one["aion"] + 0.015
    assert nll["aion"] > nll["true directions"]


def test_every_hours_prior_at_once_is_the_pairs_prior() -> None:
    """κ_t's estimate reads the priors of every profile bin of its entries at once
    (``hourly_priors``): the same bits as ``hour_prior`` at each (entry, bin) pair."""
    rng = np.random.default_rng(6)
    hourly = _hourly(True, 5, 30, rng)
    shift = GroupShift.of(hourly, _histogram(hourly), None, H)
    assert shift is not None
    static = rng.dirichlet(np.ones(B), 7)
    groups = rng.integers(0, 5, 7)
    pairs = hour_prior(np.repeat(static, H, 0), shift, np.repeat(groups, H),
                       np.tile(np.arange(H), 7))  # fmt: skip
    assert np.array_equal(hourly_priors(static, shift, groups), pairs)


def test_a_kind_of_day_never_observed_adds_no_detections_to_a_group() -> None:
    """A map of weekdays only (the weekend's 24 bins never observed): its groups' weekend
    hours take the weekday's counts for their shift (``by_hour``), as an entry's profile
    does, but those are the weekday's detections again, not more: which groups hold κ_G
    directed detections (``telling``, whose shift lets a sparse member score its
    time-varying families) counts each detection once, as a map of the weekday bins alone
    would (it counted them twice)."""
    rng = np.random.default_rng(7)
    weekdays = _hourly(True, 12, 40, rng)
    weekdays[6:] = 0.0
    weekdays[6:, 0, 9] = 2.0  # six groups of two detections, fewer than κ_G (about 2.4)
    hourly = np.concatenate([weekdays, np.zeros_like(weekdays)], axis=2)  # [G, B, 2H]
    unseen = np.arange(2 * H) >= H
    shift = GroupShift.of(hourly, _histogram(weekdays), unseen, H)
    alone = GroupShift.of(weekdays, _histogram(weekdays), None, H)
    assert shift is not None
    assert alone is not None
    np.testing.assert_array_equal(shift.ratio[:, H:], shift.ratio[:, :H])  # the weekday's
    assert 2.0 < shift.kappa < 4.0
    assert shift.telling.tolist() == [True] * 6 + [False] * 6
    assert np.array_equal(shift.telling, alone.telling)


def test_kappa_g_counts_a_never_observed_kind_of_day_as_no_evidence() -> None:
    """κ_G is fitted on the (group, hour) rows observed. A map of weekdays only whose three
    groups keep to the hour on six (group, hour) rows, 20 detections each: too few rows to
    estimate κ_G from (``MIN_ENTRIES``: 10), so no shift, as the same weekdays in a profile
    of one kind of day have none; the weekend's copies of those six rows (``by_hour``) made
    twelve, and a shift. And where the weekend was observed 10-14 h (half east, half west:
    no hour there) κ_G is the one of the same observed rows laid out without a bin unseen
    (28 "hours"), not weighed toward the weekday's hours the copies repeat."""
    few = np.zeros((3, B, H))
    few[:, 0, 9] = 20.0  # east at 09:00
    few[:, 4, 18] = 20.0  # west at 18:00
    hist = _histogram(few)
    unseen = np.arange(2 * H) >= H
    assert GroupShift.of(few, hist, None, H) is None
    assert GroupShift.of(np.concatenate([few, np.zeros_like(few)], axis=2), hist, unseen, H) is None

    rng = np.random.default_rng(8)
    weekdays = _hourly(True, 12, 40, rng)
    weekend = np.zeros_like(weekdays)
    weekend[:, :, 10:14] = _hourly(False, 12, 40, rng)[:, :, 10:14]
    hourly = np.concatenate([weekdays, weekend], axis=2)  # [G, B, 2H]
    hist = _histogram(hourly)
    seen = np.r_[np.arange(H), H + np.arange(10, 14)]
    unseen = np.ones(2 * H, bool)
    unseen[seen] = False
    shift = GroupShift.of(hourly, hist, unseen, H)
    laid_out = GroupShift.of(hourly[:, :, seen], hist, None, H)
    assert shift is not None
    assert laid_out is not None
    assert shift.kappa == laid_out.kappa
    # the unseen weekend hours still take the weekday's hour for their shift
    np.testing.assert_array_equal(shift.ratio[:, H + 9], shift.ratio[:, 9])
