"""Track linking and track differencing: synthetic walkers with known headings, speeds and
identities, invariants over random scenes, edge cases and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.engine.tracking import LinkerConfig, difference_tracks, link_tracks
from aion_cli.errors import ConfigError, InputError

S = 1_000_000_000
T0 = 1_496_999_627 * S


def walker(
    start: tuple[float, float],
    heading: float,
    speed: float,
    times_s: np.ndarray,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(t_ns, xy) of a person walking a straight line at constant velocity."""
    d = speed * (times_s - times_s[0])
    xy = np.stack([start[0] + d * math.cos(heading), start[1] + d * math.sin(heading)], axis=1)
    if noise:
        assert rng is not None
        xy = xy + rng.normal(0.0, noise, xy.shape)
    return T0 + np.round(times_s * S).astype(np.int64), xy


def scene(*people: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Concatenated rows of several walkers and which walker each row is."""
    t = np.concatenate([p[0] for p in people])
    xy = np.concatenate([p[1] for p in people])
    who = np.concatenate([np.full(len(p[0]), k) for k, p in enumerate(people)])
    return t, xy, who


def assert_one_track_each(track_id: np.ndarray, who: np.ndarray) -> None:
    """Every walker is exactly one track and no track holds two walkers."""
    for k in np.unique(who):
        assert len(np.unique(track_id[who == k])) == 1, k
    assert len(np.unique(track_id)) == len(np.unique(who))


# ----------------------------------------------------------------------------- known answers


def test_straight_walkers_in_eight_directions() -> None:
    times = np.arange(0, 20, 0.5)  # 2 Hz for 20 s
    people = []
    truth = []
    for k in range(8):
        heading = -math.pi + k * math.pi / 4 + 0.1
        speed = 0.6 + 0.1 * k
        # 20 m apart: never inside one another's gate
        people.append(walker((20.0 * k, 0.0), heading, speed, times))
        truth.append((heading, speed))
    t, xy, who = scene(*people)
    links = link_tracks(t, xy)
    assert_one_track_each(links.track_id, who)
    assert links.n_tracks == 8
    for k, (heading, speed) in enumerate(truth):
        np.testing.assert_allclose(links.heading[who == k], heading, atol=1e-9)
        np.testing.assert_allclose(links.speed[who == k], speed, rtol=1e-6)


def test_head_on_passing_needs_the_constant_velocity_prediction() -> None:
    # Two people walk towards each other 0.3 m apart laterally, 0.5 m per frame: at the
    # passing frame each one's *last* position is nearer the other's new position, so only
    # the predicted positions keep the identities.
    times = np.arange(0, 10, 0.5)
    a = walker((-2.25, 0.0), 0.0, 1.0, times)
    b = walker((2.25, 0.3), math.pi, 1.0, times)
    t, xy, who = scene(a, b)
    links = link_tracks(t, xy)
    assert_one_track_each(links.track_id, who)
    np.testing.assert_allclose(links.heading[who == 0], 0.0, atol=1e-9)
    np.testing.assert_allclose(np.abs(links.heading[who == 1]), math.pi, atol=1e-9)


def test_crossing_walkers_keep_their_tracks_and_headings() -> None:
    times = np.arange(0, 12, 0.5)
    a = walker((-6.0, 0.0), 0.0, 1.0, times)  # through the origin at t = 6 s
    b = walker((0.0, -6.25), math.pi / 2, 1.0, times)  # 0.25 s later
    c = walker((5.0, 5.0), -3 * math.pi / 4, 1.2, times)  # diagonally through the same place
    t, xy, who = scene(a, b, c)
    links = link_tracks(t, xy)
    assert_one_track_each(links.track_id, who)
    for k, heading in enumerate([0.0, math.pi / 2, -3 * math.pi / 4]):
        np.testing.assert_allclose(links.heading[who == k], heading, atol=1e-9)


def test_a_gap_longer_than_max_gap_starts_a_new_track() -> None:
    cfg = LinkerConfig(max_gap_s=2.0)
    seen = np.r_[np.arange(0, 5, 0.5), np.arange(7.5, 10, 0.5)]  # unseen for 2.5 s
    t, xy = walker((0.0, 0.0), 0.0, 1.0, seen)
    links = link_tracks(t, xy, cfg)
    before, after = seen < 6, seen > 6
    assert len(np.unique(links.track_id[before])) == 1
    assert len(np.unique(links.track_id[after])) == 1
    assert links.track_id[before][0] != links.track_id[after][0]
    # a gap of 1.5 s is bridged (the gate grows with the gap)
    seen = np.r_[np.arange(0, 5, 0.5), np.arange(6.0, 10, 0.5)]
    t, xy = walker((0.0, 0.0), 0.0, 1.0, seen)
    assert len(np.unique(link_tracks(t, xy, cfg).track_id)) == 1


def test_noisy_walkers() -> None:
    rng = np.random.default_rng(3)
    times = np.arange(0, 30, 0.5)
    truth = [(0.4, 1.0), (2.5, 1.3), (-1.9, 0.8)]
    people = [
        walker((8.0 * k, 3.0 * k), h, s, times, noise=0.03, rng=rng)
        for k, (h, s) in enumerate(truth)
    ]
    t, xy, who = scene(*people)
    links = link_tracks(t, xy)
    assert_one_track_each(links.track_id, who)
    for k, (heading, speed) in enumerate(truth):
        err = np.angle(np.exp(1j * (links.heading[who == k] - heading)))
        assert np.degrees(np.median(np.abs(err))) < 5.0
        assert np.degrees(np.abs(err).max()) < 20.0
        assert np.median(links.speed[who == k]) == pytest.approx(speed, rel=0.1)


def test_two_detections_of_one_person_in_a_frame_do_not_spoil_a_neighbour() -> None:
    # Coarse stamps: two scans 0.5 s apart share one integer-second stamp, so person A shows
    # up twice per frame; person B walks the other way 1.5 m beside A (inside A's gate).
    seconds = np.arange(0.0, 15.0)
    rear = walker((0.0, 0.0), 0.0, 1.0, seconds)
    front = (rear[0], rear[1] + [0.5, 0.0])
    b = walker((15.0, 1.5), math.pi, 1.0, seconds)
    t, xy, who = scene(rear, front, b)
    who[who == 1] = 0
    links = link_tracks(t, xy)
    b_ids = np.unique(links.track_id[who == 2])
    assert len(b_ids) == 1
    assert not np.isin(links.track_id[who == 0], b_ids).any()
    np.testing.assert_allclose(np.abs(links.heading[who == 2]), math.pi, atol=1e-9)
    a_heading = links.heading[who == 0]
    assert np.isfinite(a_heading).all()
    np.testing.assert_allclose(a_heading, 0.0, atol=1e-9)
    # no track holds two rows of one frame
    ids, frames = links.track_id, t
    assert len(set(zip(ids.tolist(), frames.tolist(), strict=True))) == len(ids)


def test_standing_person_has_no_heading_but_a_small_speed() -> None:
    rng = np.random.default_rng(0)
    times = np.arange(0, 10, 0.5)
    t, xy = walker((1.0, 1.0), 0.0, 0.0, times, noise=0.005, rng=rng)
    links = link_tracks(t, xy, LinkerConfig(min_step=0.05))
    assert len(np.unique(links.track_id)) == 1
    assert np.isnan(links.heading).all()
    assert (links.speed < 0.1).all()


# ----------------------------------------------------------------------------- invariants


@pytest.mark.parametrize("seed", range(5))
def test_invariants_on_random_scenes(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 400
    t = T0 + rng.integers(0, 60, n) * (S // 2)  # 120 possible frames, several rows each
    xy = rng.uniform(-10, 10, (n, 2))
    xy[rng.choice(n, 7, replace=False)] = [np.nan, 0.0]
    xy[rng.choice(n, 3, replace=False)] = [np.inf, np.inf]
    cfg = LinkerConfig()
    links = link_tracks(t, xy, cfg)
    finite = np.isfinite(xy).all(axis=1)
    assert (links.track_id[finite] >= 0).all()
    assert (links.track_id[~finite] == -1).all()
    assert np.isnan(links.heading[~finite]).all()
    assert np.isnan(links.speed[~finite]).all()
    ids, tt, pp = links.track_id[finite], t[finite], xy[finite]
    assert set(ids.tolist()) == set(range(links.n_tracks))
    # ids are handed out in time order: the first rows of tracks 0, 1, 2, ... are in order
    firsts = np.array([tt[ids == k].min() for k in range(links.n_tracks)])
    assert (np.diff(firsts) >= 0).all()
    for k in range(links.n_tracks):
        order = np.argsort(tt[ids == k])
        tk, pk = tt[ids == k][order], pp[ids == k][order]
        dt = np.diff(tk) / S
        assert (dt > 0).all()  # at most one row per frame
        assert (dt <= cfg.max_gap_s).all()
        # within the gate around a prediction that moves at most max_speed
        step = np.hypot(*np.diff(pk, axis=0).T)
        assert (step <= 2 * cfg.max_speed * dt + cfg.gate_slack + 1e-9).all()
    finite_h = np.isfinite(links.heading)
    assert (np.abs(links.heading[finite_h]) <= math.pi).all()
    assert (links.speed[np.isfinite(links.speed)] >= 0).all()


def test_row_order_does_not_matter() -> None:
    rng = np.random.default_rng(7)
    times = np.arange(0, 15, 0.5)
    people = [walker((6.0 * k, 0.0), 0.3 * k, 1.0, times, 0.02, rng) for k in range(4)]
    t, xy, _ = scene(*people)
    base = link_tracks(t, xy)
    perm = rng.permutation(len(t))
    shuffled = link_tracks(t[perm], xy[perm])
    # the same partition into tracks, the same headings and speeds, row by row
    relabel = dict(zip(shuffled.track_id.tolist(), base.track_id[perm].tolist(), strict=False))
    assert [relabel[k] for k in shuffled.track_id.tolist()] == base.track_id[perm].tolist()
    assert len(relabel) == base.n_tracks
    np.testing.assert_allclose(shuffled.heading, base.heading[perm])
    np.testing.assert_allclose(shuffled.speed, base.speed[perm])


# ----------------------------------------------------------------------------- edge cases


def test_empty_single_and_one_frame() -> None:
    empty = link_tracks(np.zeros(0, np.int64), np.zeros((0, 2)))
    assert len(empty.track_id) == len(empty.heading) == len(empty.speed) == 0
    assert empty.n_tracks == 0
    one = link_tracks(np.array([T0]), np.array([[1.0, 2.0]]))
    assert one.track_id.tolist() == [0]
    assert np.isnan(one.heading).all()
    assert np.isnan(one.speed).all()
    # equal stamps are one frame (dt = 0): five people, five tracks, no direction yet
    same = link_tracks(np.full(5, T0), np.array([[k * 0.1, 0.0, 9.0] for k in range(5)]))
    assert sorted(same.track_id.tolist()) == [0, 1, 2, 3, 4]
    assert np.isnan(same.heading).all()
    nothing_finite = link_tracks(np.array([T0, T0 + S]), np.full((2, 2), np.nan))
    assert nothing_finite.track_id.tolist() == [-1, -1]
    assert nothing_finite.n_tracks == 0


def test_bad_input_and_config() -> None:
    with pytest.raises(InputError, match="shape"):
        link_tracks(np.array([T0, T0]), np.zeros((3, 2)))
    with pytest.raises(InputError, match="shape"):
        link_tracks(np.array([T0]), np.zeros((1, 4)))
    with pytest.raises(InputError, match="integer nanosecond"):
        link_tracks(np.array([1.5]), np.zeros((1, 2)))
    for bad in (
        {"max_speed": 0.0},
        {"gate_slack": -0.1},
        {"max_gap_s": 0.0},
        {"min_step": -1.0},
        {"heading_span_s": math.nan},
        {"velocity_smoothing": 0.0},
        {"velocity_smoothing": 1.5},
        {"max_speed": math.inf},
    ):
        with pytest.raises(ConfigError, match=next(iter(bad))):
            LinkerConfig(**bad)


# ----------------------------------------------------------------------------- differencing


def test_difference_min_step_smooths_a_slow_noisy_walker() -> None:
    # 1 cm per sample along +x with a ±4 mm zig-zag across: neighbour differences swing by
    # ~22°, central differences over >= 5 cm each way stay within ~5° (one-sided ones at the
    # track's ends within ~10°).
    n = 60
    t = np.arange(n, dtype=np.int64) * (S // 10)
    xy = np.stack([np.arange(n) * 0.01, np.where(np.arange(n) % 2 == 0, 0.004, -0.004)], axis=1)
    tid = np.zeros(n, np.int64)
    plain, _ = difference_tracks(t, tid, xy)
    smooth, speed = difference_tracks(t, tid, xy, min_step=0.05)
    assert np.degrees(np.abs(plain).max()) > 15.0
    assert np.degrees(np.abs(smooth[5:-5]).max()) < 5.0
    assert np.degrees(np.abs(smooth).max()) < 10.0
    np.testing.assert_allclose(speed, 0.1, rtol=0.05)


def test_difference_central_one_sided_and_unknown() -> None:
    # quarter circle at constant speed: central differences give the chord direction
    t = np.array([0, S, 2 * S, 5 * S], dtype=np.int64)
    xy = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [7.0, 7.0]])
    tid = np.array([4, 4, 4, 9], dtype=np.int64)
    heading, speed = difference_tracks(t, tid, xy, min_step=0.5)
    np.testing.assert_allclose(heading[:3], [3 * np.pi / 4, np.pi, -3 * np.pi / 4])
    np.testing.assert_allclose(speed[:3], [math.sqrt(2), 1.0, math.sqrt(2)])
    assert np.isnan(heading[3])
    assert np.isnan(speed[3])
    # a span too short to reach a point 0.5 m away: no heading; speed from the neighbours
    heading, speed = difference_tracks(t, tid, xy, min_step=2.0, max_span_ns=S)
    assert np.isnan(heading).all()
    np.testing.assert_allclose(speed[:3], [math.sqrt(2), 1.0, math.sqrt(2)])


def _neighbour_difference(t: np.ndarray, tid: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Reference: central / one-sided neighbour velocity, one row at a time."""
    v = np.full((len(t), 2), np.nan)
    for k in np.unique(tid):
        rows = sorted(np.flatnonzero(tid == k).tolist(), key=lambda r: (t[r], r))
        for i, r in enumerate(rows):
            a, b = rows[max(i - 1, 0)], rows[min(i + 1, len(rows) - 1)]
            if t[b] > t[a]:
                v[r] = (xy[b] - xy[a]) / ((t[b] - t[a]) / S)
    return v


def test_difference_is_the_plain_neighbour_difference_with_min_step_zero() -> None:
    from aion_cli.formats.track_csv import finite_difference

    rng = np.random.default_rng(5)
    n = 300
    t = rng.integers(0, 100, n).astype(np.int64) * S  # some equal times within a track
    tid = rng.integers(0, 7, n).astype(np.int64)
    xy = rng.normal(0, 3, (n, 2))
    v = _neighbour_difference(t, tid, xy)
    for heading, speed in (difference_tracks(t, tid, xy), finite_difference(t, tid, xy)):
        np.testing.assert_allclose(heading, np.arctan2(v[:, 1], v[:, 0]), equal_nan=True)
        np.testing.assert_allclose(speed, np.hypot(v[:, 0], v[:, 1]), equal_nan=True)


def test_a_person_standing_between_walks_has_no_heading() -> None:
    """A track walks east, stands for three samples at x = 2, then walks north: where both
    neighbours stand where the row does, speed 0 and no heading (atan2(0, 0) = 0 had made
    them walk due east); the rows at the edges of the stand keep the walk's direction."""
    t = np.arange(8, dtype=np.int64) * S
    tid = np.zeros(8, np.int64)
    xy = np.array([[0, 0], [1, 0], [2, 0], [2, 0], [2, 0], [2, 0], [2, 1], [2, 2]], float)
    heading, speed = difference_tracks(t, tid, xy)
    assert np.isnan(heading[[3, 4]]).all()
    np.testing.assert_allclose(speed[[3, 4]], 0.0)
    np.testing.assert_allclose(heading[[0, 1, 2]], 0.0)  # east: (2,0) - (1,0) at row 2
    np.testing.assert_allclose(heading[[5, 6, 7]], np.pi / 2)  # north
    np.testing.assert_allclose(speed[[2, 5]], 0.5)  # half a metre a second over two steps
