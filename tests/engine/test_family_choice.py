"""Family choice against ``static``: the margin, and the small-sample t-test on daily gains
with the false-discovery rate held over the entries tested."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.temporal.choice import (
    _choose,
    benjamini_hochberg,
    count_quantiles,
    dispersion,
    student_t_sf,
)
from aion_cli.engine.types import F64


@pytest.mark.parametrize("df", [1, 2, 3, 4, 5, 10, 29, 30, 31, 120, 401])
def test_student_t_sf_matches_scipy(df: int) -> None:
    """The closed-form tail equals scipy's Student t survival function, both tails and zero."""
    from scipy import stats

    t = np.array([-8.0, -2.0, -0.3, 0.0, 0.3, 1.0, 1.7, 2.92, 6.314, 12.0, 40.0])
    np.testing.assert_allclose(student_t_sf(t, df), stats.t.sf(t, df), rtol=1e-9, atol=1e-15)


def test_student_t_sf_known_quantiles_and_mixed_degrees() -> None:
    """Table quantiles give 5 %; one call may mix degrees of freedom; df = 0 is refused."""
    quantiles = np.array([6.314, 2.920, 1.812, 1.697])
    np.testing.assert_allclose(student_t_sf(quantiles, [1, 2, 10, 30]), 0.05, atol=2e-4)
    assert student_t_sf(0.0, 7) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="degrees of freedom"):
        student_t_sf(1.0, 0)


@pytest.mark.parametrize("big", [257, 1_000, 200_001, 200_000])
def test_student_t_sf_of_pooled_draws_matches_scipy_without_a_term_per_degree(
    big: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A group's or the map's pooled test has as many degrees of freedom as (member, day)
    draws, 10^5 on a big map: mixed with entries' few days in one call, every tail still equals
    scipy's, and the closed form's series (a vector step per two degrees) never runs to it."""
    from scipy import stats

    from aion_cli.engine.temporal import choice

    ran: list[int] = []
    series = choice._series_sf

    def counted(tt: F64, nu: np.ndarray) -> F64:
        ran.append(int(nu.max()))
        return series(tt, nu)

    monkeypatch.setattr(choice, "_series_sf", counted)
    t = np.array([-3.0, 0.0, 0.5, 1.645, 2.0, 4.0, 2.0, 1.0])
    df = np.array([big, big, big, big, 3, 4, 256, big])
    np.testing.assert_allclose(student_t_sf(t, df), stats.t.sf(t, df), rtol=1e-9, atol=1e-15)
    assert ran == [256]
    assert student_t_sf(0.0, big) == pytest.approx(0.5)


def test_benjamini_hochberg_by_hand() -> None:
    """m = 5 at rate 0.05: thresholds 0.01, 0.02, 0.03, 0.04, 0.05. p_(3) = 0.025 <= 0.03 is
    the largest that passes, so the three smallest are rejected — 0.015 among them although it
    is above its own threshold 0.01 — and 0.045 (> 0.04) and 0.9 are not."""
    p = np.array([0.9, 0.015, 0.001, 0.045, 0.025])
    np.testing.assert_array_equal(benjamini_hochberg(p), [False, True, True, False, True])
    assert not benjamini_hochberg(np.array([0.02, 0.9, 0.9, 0.9])).any()  # 0.02 > 0.05 / 4
    assert benjamini_hochberg(np.array([0.04])).tolist() == [True]  # m = 1: the plain test
    # "p_(k) <= rate k / m": p-values exactly at their thresholds are rejected
    assert benjamini_hochberg(np.array([0.05])).tolist() == [True]
    assert benjamini_hochberg(np.array([0.05, 0.025])).tolist() == [True, True]
    assert benjamini_hochberg(np.array([])).size == 0


def _entries(daily_gains: list[list[float]]) -> tuple[F64, tuple[F64, F64, int]]:
    """Scores of (static, other) per entry from its daily gains of ``other`` over static."""
    totals = np.array([sum(g) for g in daily_gains])
    scores = np.column_stack([np.zeros(len(totals)), totals])
    gain_sq = np.column_stack([np.zeros(len(totals)), [sum(x * x for x in g) for g in daily_gains]])
    days: F64 = np.array([float(len(g)) for g in daily_gains])
    return scores, (gain_sq, days, 0)


def test_a_family_must_win_consistently_the_more_so_the_fewer_the_days() -> None:
    """Every entry gains 6 nats a day on average over ``static``; only those whose daily gains
    pass the one-sided 5 % t-test (sample variance, n - 1 degrees of freedom) switch. Entry 3
    (gains 4 and 8: t = 3.0 on one degree of freedom) passed the old fixed two-standard-error
    rule with the population variance (4.2) but is not evidence enough from two days."""
    gains = [
        [5.0, 6.0, 7.0],  # t = 10.4 > 2.92: switches
        [1.0, 12.0, 5.0],  # t = 1.87 < 2.92: stays static
        [10.0, 10.5],  # t = 41 > 6.31: switches
        [4.0, 8.0],  # t = 3.0 < 6.31: stays static
        [6.0] * 8,  # no spread at all: switches
        [30.0],  # one day shows no consistency, however large its gain: stays static
    ]
    scores, consistency = _entries(gains)
    chosen = _choose(scores, np.zeros(len(gains), np.int64), np.array([True, True]), 3.0,
                     consistency)
    np.testing.assert_array_equal(chosen, [1, 0, 1, 0, 1, 0])


def test_the_t_test_uses_the_sample_variance_of_the_daily_gains() -> None:
    """Gains 8 and 12: mean 10, sample variance (2² + 2²) / (2 − 1) = 8, t = 10 √2 / √8 = 5.0
    on one degree of freedom, p = 0.063 (scipy): not evidence at 5 %, the entry stays static
    (a variance divided by n + 1 would give t = 8.7, p = 0.036, and switch it)."""
    from scipy import stats

    assert stats.t.sf(5.0, 1) == pytest.approx(0.0628, abs=1e-4)
    scores, consistency = _entries([[8.0, 12.0]])
    chosen = _choose(scores, np.zeros(1, np.int64), np.array([True, True]), 3.0, consistency)
    assert chosen.tolist() == [0]
    scores, consistency = _entries([[9.0, 11.0]])  # t = 10.0, p = 0.032: switches
    chosen = _choose(scores, np.zeros(1, np.int64), np.array([True, True]), 3.0, consistency)
    assert chosen.tolist() == [1]


def test_one_scored_day_moves_no_entry_to_a_time_varying_family_of_its_own() -> None:
    """Families (static, shape, fremen), one scored day. An entry whose default is static
    keeps it whatever the day's gain; so does an entry borrowing its room's shape, however
    far its own FreMEn beat the shape that day (one day's win shows no consistency, against
    a borrowed default as against static). Leaving the borrowed shape for ``static``, the
    simpler family, needs no consistency: it beat the shape by 5 nats and is chosen."""
    scores = np.array([[0.0, 20.0, 30.0], [0.0, 20.0, 30.0], [0.0, 20.0, 22.0], [0.0, -5.0, -9.0]])
    gain_sq = scores**2
    days = np.ones(4)
    default = np.array([0, 1, 1, 1], np.int64)
    enabled = np.array([True, True, True])
    chosen = _choose(scores, default, enabled, 3.0, (gain_sq, days, 0))
    assert chosen.tolist() == [0, 1, 1, 0]


def test_leaving_a_borrowed_default_for_fremen_needs_consistent_daily_gains() -> None:
    """Families (static, shape, fremen), four scored days, every entry's default its room's
    shape (daily gain 5 over static, every day). Entry 0's FreMEn gains over static 5, 6, 7, 6
    nats a day beside 5 for the shape (t = 14.7 on 3 degrees of freedom, p = 0.0003): it
    switches. Entry 1's FreMEn gains 40, -15, 20, -15 (30 in all, 10 above the shape: past the
    margin) are one lucky day and three poor ones (t = 0.55, p = 0.31): it keeps the shape
    (before, leaving a borrowed default needed only the margin, and it chose FreMEn). The
    p-values by scipy."""
    from scipy import stats

    fremen_daily = [[5.0, 6.0, 7.0, 6.0], [40.0, -15.0, 20.0, -15.0]]
    for gains, p in zip(fremen_daily, (0.0003, 0.31), strict=True):
        g = np.array(gains)
        t = g.mean() / (g.std(ddof=1) / np.sqrt(g.size))
        assert stats.t.sf(t, g.size - 1) == pytest.approx(p, abs=0.01 if p > 0.01 else 1e-4)
    scores = np.array([[0.0, 20.0, sum(g)] for g in fremen_daily])
    gain_sq = np.array([[0.0, 4 * 25.0, sum(x * x for x in g)] for g in fremen_daily])
    days = np.full(2, 4.0)
    default = np.ones(2, np.int64)
    chosen = _choose(scores, default, np.array([True, True, True]), 3.0, (gain_sq, days, 0))
    assert chosen.tolist() == [2, 1]


def test_a_gain_of_exactly_the_margin_is_not_more_than_it() -> None:
    """A family replaces the default only if it beats it by *more* than the margin."""
    scores = np.array([[0.0, 3.0], [0.0, 3.5], [2.0, 5.0]])
    chosen = _choose(scores, np.zeros(3, np.int64), np.array([True, True]), 3.0)
    assert chosen.tolist() == [0, 1, 0]


def test_the_margin_still_applies() -> None:
    """A consistent but small total gain (2 nats over 4 days) stays below the 3-nat margin."""
    scores, consistency = _entries([[0.5, 0.5, 0.5, 0.5]])
    chosen = _choose(scores, np.zeros(1, np.int64), np.array([True, True]), 3.0, consistency)
    assert chosen.tolist() == [0]
    disabled = _choose(scores * 10, np.zeros(1, np.int64), np.array([True, False]), 3.0,
                       consistency)
    assert disabled.tolist() == [0]


def test_many_entries_tested_at_once_hold_the_false_discovery_rate() -> None:
    """A thousand entries whose daily gains are pure noise (mean 0) let dozens through a plain
    5 % test on the lucky side; with the rate held over all of them, the twenty entries with a
    real, consistent gain still switch and at most a false one or two come with them."""
    rng = np.random.default_rng(7)
    noise = rng.normal(0.0, 5.0, size=(1000, 4))
    real = rng.normal(6.0, 0.5, size=(20, 4))
    gains = np.vstack([noise, real]).tolist()
    scores, consistency = _entries(gains)
    enabled = np.array([True, True])
    chosen = _choose(scores, np.zeros(len(gains), np.int64), enabled, 3.0, consistency)
    assert chosen[1000:].tolist() == [1] * 20
    assert chosen[:1000].sum() <= 2
    alone = [_choose(scores[i : i + 1], np.zeros(1, np.int64), enabled, 3.0,
                     (consistency[0][i : i + 1], consistency[1][i : i + 1], 0))[0]
             for i in range(1000)]
    assert sum(alone) > 20  # the same noise tested one entry at a time does get through


def test_dispersion_by_hand() -> None:
    """φ_e = (χ²_e + 10 φ_map) / (scored_e + 10) for the chosen family, φ_map = Σ χ² / Σ scored
    of that family over the map (at least 1), φ_e at least 1. Families (static, profile):
    map φ = 300 / 60 = 5 for static, 30 / 60 -> 1 for profile."""
    chi2 = np.array([[120.0, 10.0], [180.0, 20.0], [0.0, 0.0]])
    scored = np.array([40.0, 20.0, 0.0])
    family = np.array([0, 1, 0])
    phi = dispersion(chi2, scored, family)
    expected = [(120.0 + 10 * 5.0) / 50.0, max((20.0 + 10 * 1.0) / 30.0, 1.0), 5.0]
    np.testing.assert_allclose(phi, expected, rtol=1e-12)
    assert expected == [3.4, 1.0, 5.0]
    over = dispersion(np.array([[90.0]]), np.array([10.0]), np.zeros(1, np.int64))
    assert over[0] == pytest.approx(9.0)  # one entry: the map's own φ, (90 + 90) / 20
    nothing = dispersion(np.zeros((2, 1)), np.zeros(2), np.zeros(2, np.int64))
    np.testing.assert_array_equal(nothing, [1.0, 1.0])  # nothing scored: Poisson


def test_a_zero_mean_count_is_zero_at_every_quantile() -> None:
    """Mean 0 (an entry nobody uses at that hour): every quantile is 0, Poisson or not; a
    negative or unknown mean has no quantile."""
    mean = np.array([0.0, 0.0, -1.0, np.nan])
    var = np.array([0.0, 5.0, 1.0, 1.0])
    for q in (0.1, 0.5, 0.9):
        np.testing.assert_array_equal(count_quantiles(mean, var, q), [0.0, 0.0, np.nan, np.nan])


def test_entries_borrow_the_family_their_group_chose() -> None:
    """Two groups of ten entries, every one's ``shape`` 40 nats above ``static``. In group 0,
    nine entries' own ``profile`` beats the borrowed ``shape`` by 1 nat (below the 3-nat margin
    one by one) and the tenth's shape beats its profile by 5 nats: 4 nats summed, a clear
    ``profile`` for the group, so its nine forecast with their own profiles, shrunk toward the
    shape (the group's day-ahead evidence says its places keep rhythms of their own; one
    entry's 1 nat could not), and the tenth keeps the shape. In group 1 the profile loses by
    0.5 nat each: the group, and its entries, borrow the shape (the map, 1 nat against the
    profile, chose the shape too)."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.temporal.choice import choose_families
    from aion_cli.engine.temporal.params import TemporalParams

    params = TemporalParams(ModelConfig())
    flow = params.flow
    static, shape, profile = (flow.index(f) for f in ("static", "shape", "profile"))
    scores = np.full((20, len(flow)), -100.0)
    scores[:, static] = -40.0
    scores[:, shape] = 0.0
    scores[:10, profile] = 1.0
    scores[10:, profile] = -0.5
    scores[9, profile] = -5.0
    groups = np.repeat(np.arange(2), 10)
    consistency = (scores**2, np.full(20, 4.0))
    chosen, _direction, _map = choose_families(
        params, scores, np.zeros((20, len(params.direction))), groups, 2, consistency
    )
    names = [flow[c] for c in chosen]
    assert names[:9] == ["profile"] * 9
    assert names[9] == "shape"
    assert names[10:] == ["shape"] * 10


def test_fremen_rows_change_no_entry_that_did_not_choose_fremen() -> None:
    """``fremen_rows`` (a map read without its Fourier sums) keeps FreMEn only from entries
    that would choose it without stored components; an entry that did not choose FreMEn
    anyway must choose as with the sums read, or the stored components' forecasts differ from
    the sums'. Entry 0: against its ``static`` default, ``fremen1`` scores 10 nats, all on one
    day of four (not consistent: it keeps ``static``, so the map stores no components for
    it), and ``profile`` 8 nats, 2 every day (consistent, but below FreMEn, so never the best
    family). Masking FreMEn for it made ``profile`` the best and chose it."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.temporal.choice import choose_families
    from aion_cli.engine.temporal.params import TemporalParams

    params = TemporalParams(ModelConfig())
    flow = params.flow
    static, profile, fremen = (flow.index(f) for f in ("static", "profile", "fremen1"))
    scores = np.full((2, len(flow)), -100.0)
    scores[:, static] = 0.0  # entry 1 (and so the group) plainly static
    scores[0, profile] = 8.0
    scores[0, fremen] = 10.0
    gain_sq = np.full((2, len(flow)), 4 * 25.0**2)
    gain_sq[0, static] = 0.0
    gain_sq[0, profile] = 4 * 2.0**2
    gain_sq[0, fremen] = 10.0**2
    days = np.full(2, 4.0)
    groups = np.zeros(2, np.int64)
    directions = np.zeros((2, len(params.direction)))
    with_sums, _, _ = choose_families(params, scores, directions, groups, 1, (gain_sq, days))
    assert [flow[c] for c in with_sums] == ["static", "static"]
    without, _, _ = choose_families(
        params, scores, directions, groups, 1, (gain_sq, days), fremen_rows=np.zeros(2, bool)
    )
    assert [flow[c] for c in without] == ["static", "static"]


def test_a_group_lends_the_profile_direction_only_on_two_scored_days() -> None:
    """Twenty entries of one group, each entry's ``profile`` directions 2 nats a day above
    ``static`` (1 nat each alone, under the 3-nat margin: no entry leaves ``static`` on its
    own). Over two scored days each, every (member, day) gain the same, the group's 40 nats pass
    the consistency test and it lends ``profile`` to all twenty. Over one scored day the same
    20 nats are one day's evidence however many members show it: nothing is lent, as an entry
    with one scored day keeps ``static`` (before the rule, Lincoln's two-day split lent
    ``profile`` on its first day and its heading NLL fell behind static's)."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.temporal.choice import choose_families
    from aion_cli.engine.temporal.params import TemporalParams

    params = TemporalParams(ModelConfig())
    direction = params.direction
    static, profile = direction.index("static"), direction.index("profile")
    flow = np.zeros((20, len(params.flow)))
    groups = np.zeros(20, np.int64)
    lent = {}
    for days, gain_a_day in ((2.0, 1.0), (1.0, 1.0)):
        scores = np.full((20, len(direction)), -100.0)
        scores[:, static] = 0.0
        scores[:, profile] = days * gain_a_day
        gain_sq = np.zeros_like(scores)
        gain_sq[:, profile] = days * gain_a_day**2
        # the t-test needs spread: one member's days differ a little
        gain_sq[0, profile] += 0.01
        _, chosen, _ = choose_families(
            params, flow, scores, groups, 1, None, (gain_sq, np.full(20, days))
        )
        lent[days] = {direction[c] for c in chosen}
    assert lent[2.0] == {"profile"}
    assert lent[1.0] == {"static"}


def test_group_sums_add_each_groups_rows_in_order_as_add_at_did() -> None:
    """The groups' summed scores (``pooling.group_sums``, which the choice pools with) are the
    same to the bit as adding each entry's row into zeros in entry order (``np.add.at``, what
    the choice summed with at stop 68): scores of mixed magnitudes, whose float sums depend
    on the order, groups in any order and one group with no member (zeros)."""
    from aion_cli.engine.temporal.pooling import group_sums

    rng = np.random.default_rng(11)
    scores = rng.standard_normal((5000, 7)) * 10.0 ** rng.integers(-6, 9, (5000, 7))
    groups = rng.integers(0, 40, 5000)
    groups[groups == 17] = 18  # group 17 has no member
    expected = np.zeros((40, 7))
    np.add.at(expected, groups, scores)
    got = group_sums(groups, 40, scores)
    assert got.tobytes() == expected.tobytes()
    assert not got[17].any()
    # the order matters to the bits (so the comparison above could fail): summed backwards
    backwards = np.zeros((40, 7))
    np.add.at(backwards, groups[::-1], scores[::-1])
    assert backwards.tobytes() != expected.tobytes()


def test_the_map_lends_the_profile_direction_on_the_draws_its_gains_are_summed_over() -> None:
    """The map's choice of a direction family to lend is tested on its entries' (member,
    day) gains: the mean gain a draw is the gains' sum over the draws that made it. Ten
    entries of group 0 scored on one day each, ``profile`` 3 nats above ``static`` on five and
    1 nat below it on five (10 nats in all, erratic: t = 1.5 over twelve draws, p = 0.08); one
    entry of group 1 scored on two days, +0.1 and -0.1. Summed over every group but counted
    over group 1's two days only, the map's mean gain was 5 nats a draw with no spread, its
    test passed and it lent ``profile`` to group 0, whose members have one scored day each."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.temporal.choice import choose_families
    from aion_cli.engine.temporal.params import TemporalParams

    params = TemporalParams(ModelConfig())
    direction = params.direction
    static, profile = direction.index("static"), direction.index("profile")
    scores = np.full((11, len(direction)), -100.0)
    scores[:, static] = 0.0
    gains = np.array([3.0, -1.0] * 5)
    scores[:10, profile] = gains
    scores[10, profile] = 0.0  # +0.1 and -0.1
    gain_sq = np.zeros_like(scores)
    gain_sq[:10, profile] = gains**2
    gain_sq[10, profile] = 0.02
    days = np.array([1.0] * 10 + [2.0])
    groups = np.array([0] * 10 + [1], np.int64)
    flow = np.zeros((11, len(params.flow)))
    _, chosen, _ = choose_families(params, flow, scores, groups, 2, None, (gain_sq, days))
    assert [direction[c] for c in chosen] == ["static"] * 11
