"""Issue 15, per-window and per-day repeats: each fast path gives exactly what the code it
replaced gave (verbatim copies below), bit for bit.

* A day's per-window FreMEn sums of fixed-sensor slots evaluated a block of every order at
  once (:class:`~aion_cli.engine.temporal.slot_sums.FixedSlots`) against the per-order
  blocks, on random forecasts, slots, shares and chunk sizes (hypothesis).
* A bind check that finds nothing new before listing the cells (``ownership.plan_binds``)
  against the check that listed them first: whole builds, fixed sensor and robot, equal
  member by member, with the same cells queried.
* ``MapState.window_day`` bringing the days of the windows ahead against one calendar call
  per window, in any order, across DST changes, for windows of a second to half a day.
* A day's sums of the static, shape and profile rates over the observed windows
  (``scoring._observed_sum``) evaluated at broadcast (entry, bin) indices against the
  repeated pair arrays, with and without the profile sums held.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.engine import closing, merge, ownership
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.nearest import BindIndex
from aion_cli.engine.ownership import BindPlan, stable_nodes
from aion_cli.engine.state import MapState
from aion_cli.engine.temporal import model as temporal_model
from aion_cli.engine.temporal import scoring
from aion_cli.engine.types import F64, I64
from tests.engine import test_issue15_windows as window_builds

C128 = Any


# -- the per-window FreMEn sums of fixed-sensor slots ---------------------------------------


def _per_window_sums_per_order(
    fc: Any,
    entries: I64,
    fixed: tuple[I64, F64 | None],
    own: tuple[I64, I64, F64],
    rot: C128,
    floor: float,
) -> F64:
    """``scoring._per_window_sums`` before its blocks held every order: one (slot × entry)
    block per order (verbatim but for the names of the chunk size and of this copy)."""
    fixed_slots, fixed_share = fixed
    slot_of = np.full(fc.rows.size, -1, np.int64)
    slot_of[entries] = np.arange(entries.size)
    obs_e, obs_s, obs_w = own
    mine = slot_of[obs_e] >= 0
    own_e, own_s, own_w = obs_e[mine], obs_s[mine], obs_w[mine]
    m_max = fc.params.max_order
    n_fixed = fixed_slots.size
    fixed_pairs = entries.size * n_fixed
    n_pairs = fixed_pairs + own_e.size
    coef, rate, idx = fc.coef_total[entries], fc.rate_total[entries], fc.period_idx[entries]
    # 2 Re(γ z) = Re γ · 2 Re z − Im γ · 2 Im z, z = e^{−iωt}: real arithmetic on a period's
    # slots (rows of (K, S) tables), no complex temporaries
    # (S, K) tables, entries along the columns of each block: a block's sum over its slots is
    # then a reduction over the outer axis, which adds the slots in order (as bincount's
    # running sums do) without an accumulation's full output
    fixed_rot = rot[fixed_slots]
    cos2 = np.ascontiguousarray(2.0 * fixed_rot.real)
    sin2 = np.ascontiguousarray(2.0 * fixed_rot.imag)
    coef_re, coef_im = np.ascontiguousarray(coef.real), np.ascontiguousarray(coef.imag)
    slot = np.arange(n_fixed)
    total = np.zeros((m_max, entries.size))
    for a in range(0, n_pairs, scoring._PAIRS):
        b = min(a + scoring._PAIRS, n_pairs)
        chunk = np.zeros((m_max, entries.size))
        if a < fixed_pairs:  # entries [i0, i1) have fixed pairs in [a, min(b, fixed_pairs))
            fb = min(b, fixed_pairs)
            i0, i1 = a // n_fixed, (fb - 1) // n_fixed + 1
            pair = slot[:, None] + np.arange(i0, i1)[None, :] * n_fixed  # (S, nb)
            inside = (pair >= a) & (pair < fb)
            whole = bool(inside.all())
            terms = np.zeros((n_fixed, i1 - i0))
            lam = np.empty_like(terms)
            for j in range(m_max):  # the running sum over orders (cumsum's order)
                k = idx[i0:i1, j]
                part = coef_re[None, i0:i1, j] * cos2.take(k, axis=1)
                part -= coef_im[None, i0:i1, j] * sin2.take(k, axis=1)
                terms += part
                np.add(rate[None, i0:i1], terms, out=lam)
                np.maximum(lam, floor, out=lam)  # (S, nb)
                if fixed_share is not None:  # expected detections: λ times the share
                    lam *= fixed_share[:, None]
                if not whole:  # adding 0.0 leaves a sum of positive terms unchanged
                    lam[~inside] = 0.0
                chunk[j, i0:i1] = _sum_in_order(lam)
        if b > fixed_pairs:
            e = own_e[max(a, fixed_pairs) - fixed_pairs : b - fixed_pairs]
            s = own_s[max(a, fixed_pairs) - fixed_pairs : b - fixed_pairs]
            w = own_w[max(a, fixed_pairs) - fixed_pairs : b - fixed_pairs]
            z = rot[s[:, None], fc.period_idx[e]]  # (P, M), as the fixed slots' terms
            coef_e = fc.coef_total[e]
            terms = np.cumsum(coef_e.real * (2.0 * z.real) - coef_e.imag * (2.0 * z.imag), axis=1)
            lam_own = np.maximum(fc.rate_total[e][:, None] + terms, floor)  # (P, M)
            lam_own *= w[:, None]
            local = slot_of[e]
            for j in range(m_max):
                np.add.at(chunk[j], local, lam_own[:, j])  # in pair order, after the fixed
        total += chunk
    return total


def _sum_in_order(values: F64) -> F64:
    """Column sums of ``values`` (S, n) adding the rows one after the other, as running sums
    do: numpy reduces over the outer axis of a 2-D array that way (a sum along a contiguous
    row may be pairwise), except for a single column, which it reduces as a contiguous run
    (tested against the pair-by-pair sums bit for bit)."""
    if values.shape[1] == 1:
        out: F64 = np.add.accumulate(values[:, 0])[-1:]
        return out
    summed: F64 = np.add.reduce(values, axis=0)
    return summed


def _forecast(rng: np.random.Generator, rows: int, m: int, k: int) -> SimpleNamespace:
    """What ``_per_window_sums`` reads of a forecaster: rates, FreMEn coefficients and
    periods (rates near zero, so the floor bites somewhere)."""
    return SimpleNamespace(
        rows=np.arange(rows),
        params=SimpleNamespace(max_order=m),
        rate_total=rng.exponential(0.3, rows) * (rng.random(rows) < 0.9),
        coef_total=rng.normal(0, 0.2, (rows, m)) + 1j * rng.normal(0, 0.2, (rows, m)),
        period_idx=rng.integers(0, k, (rows, m)),
    )


@pytest.mark.parametrize("chunk", [1, 7, 100, 1 << 15])
@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_blocks_of_every_order_equal_the_per_order_blocks(
    chunk: int, seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Chunks that cut entries' slots anywhere (one pair, a few, most of an entry), one to
    four orders, whole or partly recorded slots, own pairs after the fixed ones."""
    monkeypatch.setattr(scoring, "_PAIRS", chunk)
    rng = np.random.default_rng(seed)
    rows, m, k, slots = int(rng.integers(1, 50)), int(rng.integers(1, 5)), 9, 40
    fc = _forecast(rng, rows, m, k)
    t = np.sort(rng.uniform(0, 86_400, slots))
    rot = np.exp(-1j * np.multiply.outer(t, rng.uniform(1e-5, 1e-3, k)))
    fixed_slots = np.flatnonzero(rng.random(slots) < rng.uniform(0, 1))
    share = None if seed % 3 else np.where(
        rng.random(fixed_slots.size) < 0.5, 1.0, rng.uniform(0.01, 1.0, fixed_slots.size)
    )
    entries = np.flatnonzero(rng.random(rows) < 0.7)
    n_obs = int(rng.integers(0, 100))
    obs_e = np.sort(rng.integers(0, rows, n_obs))
    own = (obs_e, rng.integers(0, slots, n_obs), rng.uniform(0.01, 1.0, n_obs))
    floor = float(rng.choice([1e-12, 1e-3, 0.05]))
    got = scoring._per_window_sums(fc, entries, (fixed_slots, share), own, rot, floor)  # type: ignore[arg-type]
    want = _per_window_sums_per_order(fc, entries, (fixed_slots, share), own, rot, floor)
    assert got.shape == want.shape
    assert got.tobytes() == want.tobytes()


def test_a_bench_sized_day_equals_the_per_order_blocks() -> None:
    """A fixed sensor's day as the 20-day bench build closes it: 144 slots, four orders,
    31 periods, a thousand entries in chunks of ``_PAIRS`` (every chunk cuts two)."""
    rng = np.random.default_rng(15)
    fc = _forecast(rng, 1000, 4, 31)
    t = np.arange(144) * 600.0
    rot = np.exp(-1j * np.multiply.outer(t, 2 * np.pi / (86_400.0 / np.arange(1, 32))))
    fixed = (np.arange(144), None)
    own = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
    entries = np.arange(1000)
    got = scoring._per_window_sums(fc, entries, fixed, own, rot, 1e-3)  # type: ignore[arg-type]
    want = _per_window_sums_per_order(fc, entries, fixed, own, rot, 1e-3)
    assert got.tobytes() == want.tobytes()


# -- the bind check that finds nothing new -----------------------------------------------------


def _plan_binds_listing_first(state: MapState, t_ns: int) -> BindPlan | None:
    """``ownership.plan_binds`` before it asked the memo first (verbatim)."""
    cfg = state.config
    stable = stable_nodes(state, t_ns)
    if state.deferred is not None and state.deferred.first_stable is None and stable.any():
        # a shard remembers the first stable nodes it bound to (engine.shards)
        state.deferred.remember_stable(state.nodes.ids[stable], state.nodes.xyz[stable])
    cells = state.entries.cell_rows()
    if not stable.any() or len(cells) == 0:
        return None
    xyz = state.nodes.xyz[stable]
    index = state.nodes.bind_index
    if index is None:
        index = state.nodes.bind_index = BindIndex()
    version = state.entries.cells_version
    if index.nothing_new(version, xyz, cfg.bind_radius, cfg.bind_vertical_tolerance):
        return None
    hit = index.nearest(
        cells,
        state.entries.key,
        state.entries.xyz,
        xyz,
        cfg.bind_radius,
        cfg.bind_vertical_tolerance,
    )
    bound = hit >= 0
    if not bound.any():
        index.bound_none(version)
        return None
    cells, hit = cells[bound], hit[bound]
    order = np.argsort(state.entries.key[cells], kind="stable")  # canonical: by cell key
    cells, hit = cells[order], hit[order]
    return BindPlan(cells, state.nodes.ids[stable][hit], xyz[hit])


@pytest.mark.parametrize("robot", [False, True])
@pytest.mark.parametrize("seed", [1, 4, 7])
def test_bind_checks_asking_the_memo_first_build_the_same_map(
    seed: int, robot: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Three days of detections and graphs whose nodes come, go and move (binds, releases,
    checks with nothing new): the same arrays, and the memo asked less often about fewer
    cells (after a check that bound none, or whose binds were made, only the cells added
    since are asked about, ``EntryStore.cells_added_since``)."""
    queried = []
    real_nearest = BindIndex.nearest

    def counted(self: BindIndex, *args: Any) -> Any:
        queried.append(int(np.asarray(args[0]).size))
        return real_nearest(self, *args)

    monkeypatch.setattr(BindIndex, "nearest", counted)
    fast = window_builds._build(seed, robot)
    fast_queried = list(queried)
    queried.clear()
    with monkeypatch.context() as patch:
        patch.setattr(ownership, "plan_binds", _plan_binds_listing_first)
        patch.setattr(closing, "plan_binds", _plan_binds_listing_first)
        patch.setattr(merge, "plan_binds", _plan_binds_listing_first)  # every copy imported
        before = window_builds._build(seed, robot)
    assert len(fast_queried) <= len(queried)
    assert sum(fast_queried) < sum(queried)
    assert sorted(fast) == sorted(before)
    for name in fast:
        assert fast[name].dtype == before[name].dtype, name
        assert fast[name].tobytes() == before[name].tobytes(), name


# -- the days of windows ---------------------------------------------------------------------


@pytest.mark.parametrize("timezone", ["UTC", "Europe/Berlin", "America/Santiago"])
@pytest.mark.parametrize("window_s", [1.0, 600.0, 5400.0, 21_600.0, 43_200.0])
@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=15, deadline=None)
def test_window_days_brought_ahead_equal_one_call_per_window(
    timezone: str, window_s: float, seed: int
) -> None:
    """Windows asked in a build's order (each next one, some repeated) and at random, near
    DST changes and far from them: every answer equals the per-window calendar call
    (windows of a second to half a day)."""
    cfg = ModelConfig(
        window_s=window_s, profile_bin_s=max(3600.0, window_s), timezone=timezone,
        periods=(86_400.0, 604_800.0),
    )
    state = MapState.empty(cfg)
    rng = np.random.default_rng(seed)
    start = int(rng.integers(1_600_000_000, 1_800_000_000)) * 10**9 // state.window_ns
    walk = start + np.cumsum(rng.integers(0, 3, 400))
    jumps = rng.integers(start - 10**4, start + 10**6, 100)
    for w in np.concatenate([walk, jumps, walk[::-1]]).tolist():
        want = temporal_model.window_day(state.params, w, state.window_ns)
        assert state.window_day(w) == want


# -- the day's sums of the periodic families over observed windows -----------------------------


def _observed_sum_by_pairs(fc: Any, name: str, per_bin: F64, floor: float, fremen: F64) -> F64:
    """``scoring._observed_sum`` before the broadcast indices: every (entry, bin) pair
    repeated into arrays (verbatim but for the name)."""
    if name.startswith("fremen"):
        out: F64 = fremen[int(name.removeprefix("fremen")) - 1]
        return out
    n = per_bin.shape[0]
    bins = np.flatnonzero(per_bin.any(axis=0))
    # every (entry, bin) pair in one evaluation, then the bins added in order
    pair_e = np.repeat(np.arange(n), bins.size)
    pair_h = np.tile(bins, n)
    lam = np.maximum(fc.flow(name, pair_e, pair_h, np.zeros(pair_e.size)), floor)
    lam = lam.reshape(n, bins.size)
    total = np.zeros(n)
    for j, b in enumerate(bins.tolist()):
        total += lam[:, j] * per_bin[:, b]
    return total


@pytest.mark.parametrize("cached", [True, False])
@pytest.mark.parametrize("seed", range(12))
def test_observed_sums_over_a_grid_equal_the_pair_sums(cached: bool, seed: int) -> None:
    """A learnt state's forecasters (profile sums held or read from the accumulators), random
    observed windows per profile bin (some bins empty, whole and partial windows), floors
    that bite or not: the static, shape and profile sums equal, bit for bit."""
    from aion_cli.engine.temporal import pooling
    from aion_cli.engine.temporal.forecast import Forecaster
    from aion_cli.engine.temporal.params import TemporalParams
    from tests.engine.test_temporal_blocks import _days, _learnt

    rng = np.random.default_rng(seed)
    params = TemporalParams.from_config(ModelConfig())
    state = _learnt(params, 30, _days(params, 30, 3, seed=seed % 7))
    rows = np.arange(30, dtype=np.int64)
    groups = rows // 6
    pool = pooling.PoolStats.of(params, state, rows, groups, 5)
    fc = Forecaster(params, state, rows, groups, pool)
    if cached:
        fc.cache_profiles()
    per_bin = rng.uniform(0.0, 3.0, (30, params.n_profile))
    per_bin *= rng.random((30, params.n_profile)) < 0.5
    per_bin[:, rng.random(params.n_profile) < 0.4] = 0.0
    floor = float(rng.choice([1e-12, 1e-3, 0.5]))
    fremen = np.zeros((params.max_order, 30))
    bins = np.flatnonzero(per_bin.any(axis=0))
    for name in ("static", "shape", "profile"):
        got = scoring._observed_sum(fc, name, per_bin, floor, fremen)
        want = _observed_sum_by_pairs(fc, name, per_bin, floor, fremen)
        assert got.tobytes() == want.tobytes(), name
        # the windows per (bin, entry) gathered once by the caller for every family
        held = scoring._observed_sum(fc, name, per_bin, floor, fremen, bins, per_bin.T[bins])
        assert held.tobytes() == want.tobytes(), name
