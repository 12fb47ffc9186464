"""The vectorised HeadingEstimator (issue 15: reset chains by pointer doubling, no loop over a
track's rows) gives exactly what the estimator it replaced gives (kept verbatim as
``tests.formats.heading_reference.RoundsHeadingEstimator``): headings, speeds, sources and the
state carried between calls, bit for bit, on random tracks with gaps longer than
``max_gap_s``, ids reused after a gap, people standing still, slow walkers, repeated stamps,
stamps out of order, NaN positions, velocities on some rows, pruning, and the stream split
into calls at arbitrary points; and one call with ``segment`` gives what one call per segment
gives."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.engine.heading import HeadingEstimator
from tests.formats.heading_reference import RoundsHeadingEstimator

S = 1_000_000_000
SETTINGS = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _same(a: Any, b: Any) -> bool:
    return bool(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True))


def _check_state(new: HeadingEstimator, old: RoundsHeadingEstimator) -> None:
    assert _same(new.ids, old.ids)
    assert _same(new.ref_t, old.ref_t)
    assert _same(new.ref_xy, old.ref_xy)
    assert _same(new.heading, old.heading)


@st.composite
def streams(draw: st.DrawFn) -> dict[str, Any]:
    """A random detection stream (rows in stream order) and where it is cut into calls."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n = draw(st.integers(0, 300))
    n_tracks = draw(st.integers(1, 12))
    k = rng.integers(-1, n_tracks, n) * draw(st.sampled_from([1, 1000]))
    rate = draw(st.sampled_from([1, 2, 5]))  # stamp steps of 0.1 s
    t = np.sort(rng.integers(0, max(1, n // rate + draw(st.integers(0, 400))), n)) * (S // 10)
    t = t + 1_700_000_000 * S
    order = draw(st.sampled_from(["sorted", "jitter", "shuffled", "equal"]))
    if order == "jitter":  # stamps a little out of order
        t = t + rng.integers(-3, 4, n) * (S // 10)
    elif order == "shuffled":
        t = rng.permutation(t)
    elif order == "equal":  # a clock that repeats itself
        t = t[0] + rng.integers(0, 3, n) * (S // 10) if n else t
    step = rng.choice([0.0, 0.001, 0.01, 0.03, 0.2, 1.0], n_tracks + 1)  # standing .. running
    stride = step[np.maximum(k, -1) % (n_tracks + 1)]
    xyz = np.cumsum(rng.normal(0.0, 1.0, (n, 3)) * stride[:, None], axis=0)
    xyz += draw(st.sampled_from([0.0, 1e6]))
    if draw(st.booleans()):
        xyz[rng.random(n) < 0.05] = np.nan
    velocity = np.full((n, 3), np.nan)
    with_v = rng.random(n) < draw(st.sampled_from([0.0, 0.2, 1.0]))
    velocity[with_v] = rng.normal(0.0, 1.0, (int(with_v.sum()), 3))
    velocity[rng.random(n) < 0.05] = 0.0
    yaw = np.where(rng.random(n) < 0.5, rng.uniform(-4.0, 4.0, n), np.nan)
    cuts = np.sort(rng.integers(0, n + 1, draw(st.integers(0, 6))))
    return {
        "t": t.astype(np.int64), "xyz": xyz, "velocity": velocity, "yaw": yaw, "k": k,
        "cuts": cuts,
        "min_displacement": draw(st.sampled_from([0.0, 0.05, 0.3])),
        "max_gap_s": draw(st.sampled_from([0.25, 1.0, 5.0, 60.0])),
        "prune_above": draw(st.sampled_from([1, 3, 4096])),
    }


@SETTINGS
@given(s=streams())
def test_equals_the_round_by_round_estimator(s: dict[str, Any]) -> None:
    args = (s["min_displacement"], s["max_gap_s"], s["prune_above"])
    new, old = HeadingEstimator(*args), RoundsHeadingEstimator(*args)
    n = len(s["t"])
    bounds = [0, *s["cuts"].tolist(), n]
    for a, b in itertools.pairwise(bounds):
        part = [s[name][a:b] for name in ("t", "xyz", "velocity", "yaw", "k")]
        got, want = new.estimate(*part), old.estimate(*part)
        assert _same(got.heading, want.heading)
        assert _same(got.speed, want.speed)
        assert _same(got.t_ns, want.t_ns)
        assert _same(got.xyz, want.xyz)
        assert _same(got.track_id, want.track_id)
        assert _same(new.sources, old.sources)
        _check_state(new, old)


@SETTINGS
@given(s=streams())
def test_one_call_with_segments_equals_one_call_per_segment(s: dict[str, Any]) -> None:
    """Segments (scene-graph intervals decoded in one job): the rows of each track are taken
    in (segment, time) order, as successive calls take them (no pruning in between: the
    state is pruned once, after the call)."""
    args = (s["min_displacement"], s["max_gap_s"], 10**9)
    n = len(s["t"])
    segment = np.searchsorted(s["cuts"], np.arange(n), side="right")
    new, old = HeadingEstimator(*args), RoundsHeadingEstimator(*args)
    cols = [s[name] for name in ("t", "xyz", "velocity", "yaw", "k")]
    got = new.estimate(*cols, segment=segment)
    heading, speed = np.full(n, np.nan), np.full(n, np.nan)
    sources = np.zeros(n, np.int8)
    for seg in np.unique(segment).tolist():
        rows = segment == seg
        want = old.estimate(*[c[rows] for c in cols])
        heading[rows], speed[rows], sources[rows] = want.heading, want.speed, old.sources
    assert _same(got.heading, heading)
    assert _same(got.speed, speed)
    assert _same(new.sources, sources)
    _check_state(new, old)


def test_a_long_batch_of_walkers_and_standers() -> None:
    """One call over 40,000 rows (a decode job): walkers, people standing for longer than the
    gap, slow walkers; equal to the reference, which needs one round per row of a track."""
    rng = np.random.default_rng(7)
    n_msg, per = 8000, 5
    t = 1_700_000_000 * S + np.repeat(np.arange(n_msg) * (S // 10), per)
    k = np.tile(np.arange(per), n_msg) + 100 * (np.arange(n_msg * per) // (per * 1500))
    step = np.array([0.5, 0.0, 0.004, 0.02, 0.1])[np.arange(n_msg * per) % per]
    xyz = np.cumsum(rng.normal(0, 1, (n_msg * per, 3)) * step[:, None], axis=0)
    new, old = HeadingEstimator(), RoundsHeadingEstimator()
    for half in (slice(0, len(t) // 2), slice(len(t) // 2, None)):
        got = new.estimate(t[half], xyz[half], None, None, k[half])
        want = old.estimate(t[half], xyz[half], None, None, k[half])
        assert _same(got.heading, want.heading)
        assert _same(got.speed, want.speed)
        _check_state(new, old)
    assert np.isfinite(got.heading).mean() > 0.5
