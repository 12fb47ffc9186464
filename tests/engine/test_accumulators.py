"""Row operations of the temporal accumulators against a plain per-pair reference: counts and
scores add, observations add (states of disjoint time) or the block with the most windows is
kept (ties: the destination's, then the first source's), whichever rows were written before."""

from __future__ import annotations

from typing import Literal

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.observation_block import _OBS_FIELDS

_ADDITIVE = (
    "cnt_fourier", "cnt_profile", "flow_score", "flow_chi2", "flow_scored", "flow_days",
    "flow_gain_sq", "dir_score", "dir_scored", "dir_days", "dir_gain_sq",
)  # fmt: skip
_SHAPE = {"values": 2, "periods": 3, "bins": 4, "flow_families": 3, "dir_families": 2}


def _state(rows: int, written: int, seed: int) -> TemporalState:
    """``rows`` rows of which the first ``written`` hold whole-number sums (exact in any
    order of addition) and observations of 1..3 windows (ties are likely); the rest were
    never written (zeros, NaN first / last)."""
    rng = np.random.default_rng(seed)
    state = TemporalState.empty(rows, **_SHAPE)
    w = slice(0, written)
    for name in _ADDITIVE:
        a = getattr(state, name)
        a[w] = rng.integers(0, 9, a[w].shape)
        if np.iscomplexobj(a):
            a[w] += 1j * rng.integers(-4, 5, a[w].shape)
    state.obs.n[w] = rng.integers(1, 4, written)
    phasors = rng.integers(-5, 6, (2, written, 3))
    state.obs.fourier[w] = phasors[0] + 1j * phasors[1]
    state.obs.profile[w] = rng.integers(0, 4, (written, 4))
    state.obs.first[w] = rng.integers(0, 100, written)
    state.obs.last[w] = state.obs.first[w] + rng.integers(0, 100, written)
    state.touch(np.arange(written))
    return state


def _snapshot(state: TemporalState) -> dict[str, np.ndarray]:
    out = {name: getattr(state, name).copy() for name in _ADDITIVE}
    out.update({"obs_" + f: getattr(state.obs, f).copy() for f in _OBS_FIELDS})
    return out


def _reference(
    mine: dict[str, np.ndarray],
    theirs: dict[str, np.ndarray],
    src: list[int],
    dst: list[int],
    observation: Literal["max", "add"],
) -> dict[str, np.ndarray]:
    """``mine[dst] += theirs[src]`` one pair at a time, ``theirs`` read before any write."""
    out = {k: v.copy() for k, v in mine.items()}
    for s, d in zip(src, dst, strict=True):
        for name in _ADDITIVE:
            out[name][d] += theirs[name][s]
    for d in sorted(set(dst)):
        sources = [s for s, dd in zip(src, dst, strict=True) if dd == d]
        if observation == "add":
            for s in sources:
                for f in ("n", "fourier", "profile"):
                    out["obs_" + f][d] += theirs["obs_" + f][s]
                out["obs_first"][d] = np.fmin(out["obs_first"][d], theirs["obs_first"][s])
                out["obs_last"][d] = np.fmax(out["obs_last"][d], theirs["obs_last"][s])
            continue
        best, best_n = None, mine["obs_n"][d]  # the destination's own block wins ties
        for s in sources:
            if theirs["obs_n"][s] > best_n:
                best, best_n = s, theirs["obs_n"][s]
        if best is not None:
            for f in _OBS_FIELDS:
                out["obs_" + f][d] = theirs["obs_" + f][best]
    return out


def _assert_same(state: TemporalState, expected: dict[str, np.ndarray]) -> None:
    got = _snapshot(state)
    for name, value in expected.items():
        np.testing.assert_array_equal(got[name], value, err_msg=name)


_PAIRS = st.lists(st.tuples(st.integers(0, 4), st.integers(0, 7)), min_size=1, max_size=8)


@given(
    pairs=_PAIRS,
    written=st.integers(0, 8),
    observation=st.sampled_from(["max", "add"]),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=300, deadline=None)
def test_add_from_is_the_per_pair_sum(
    pairs: list[tuple[int, int]],
    written: int,
    observation: Literal["max", "add"],
    seed: int,
) -> None:
    """Destinations written before, never written, or both in one call, once or repeated."""
    mine, theirs = _state(8, written, seed), _state(5, 5, seed + 1)
    src, dst = [p[0] for p in pairs], [p[1] for p in pairs]
    expected = _reference(_snapshot(mine), _snapshot(theirs), src, dst, observation)
    mine.add_from(theirs, np.array(src), np.array(dst), observation)
    _assert_same(mine, expected)


@given(
    pairs=st.lists(st.tuples(st.integers(0, 7), st.integers(0, 7)), min_size=1, max_size=8),
    observation=st.sampled_from(["max", "add"]),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=300, deadline=None)
def test_add_rows_reads_every_source_before_writing(
    pairs: list[tuple[int, int]], observation: Literal["max", "add"], seed: int
) -> None:
    """Within one state (a row may be a source and a destination): the sources' values
    before the call are what is added."""
    state = _state(8, 8, seed)
    src, dst = [p[0] for p in pairs], [p[1] for p in pairs]
    before = _snapshot(state)
    expected = _reference(before, before, src, dst, observation)
    state.add_rows(np.array(src), np.array(dst), observation)
    _assert_same(state, expected)


def test_an_entrys_observation_is_the_global_block_plus_its_own() -> None:
    """Windows, per-bin windows and the phasor sums add; first is the earlier, last the later
    of the two."""
    state = _state(2, 2, 3)
    state.glob.n[0], state.glob.profile[0] = 4.0, [1.0, 0.0, 2.0, 1.0]
    state.glob.first[0], state.glob.last[0] = 50.0, 120.0
    state.obs.first[:], state.obs.last[:] = [10.0, 60.0], [90.0, 300.0]
    own = _snapshot(state)
    got = state.observation([1, 0], fourier=False)
    np.testing.assert_array_equal(got.n, own["obs_n"][[1, 0]] + 4.0)
    np.testing.assert_array_equal(got.profile, own["obs_profile"][[1, 0]] + [1.0, 0.0, 2.0, 1.0])
    np.testing.assert_array_equal(got.first, [50.0, 10.0])
    np.testing.assert_array_equal(got.last, [300.0, 120.0])
    assert got.fourier.shape == (2, 0)
    state.glob.fourier[0] = [1 + 2j, -3j, 4.0]
    full = state.observation([1, 0])
    np.testing.assert_array_equal(full.fourier, own["obs_fourier"][[1, 0]] + [1 + 2j, -3j, 4.0])
    np.testing.assert_array_equal(state.windows_observed([1, 0]), got.n)
