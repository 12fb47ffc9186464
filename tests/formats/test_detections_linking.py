"""Id-less detections get headings from motion: the incremental ``TrackLinker`` links a stream
chunk by chunk exactly as ``link_tracks`` links it at once, the feeder links per topic across
chunks, headings are counted by source, and a zero quaternion never yields a heading."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from aion_cli.detection_feed import DetectionCounts, DetectionFeeder
from aion_cli.engine.heading import SOURCES, HeadingEstimator
from aion_cli.engine.tracking import LinkerConfig, TrackLinker, link_tracks
from aion_cli.errors import InputError
from aion_cli.formats.raw import RawMessage
from tests.formats.ros_messages import header, pose, raw

S = 1_000_000_000
T0 = 1_700_000_000 * S
ZERO_Q = (0.0, 0.0, 0.0, 0.0)


def walkers(rng: np.random.Generator, n_people: int, seconds: float, hz: float) -> tuple[
    np.ndarray, np.ndarray
]:
    """(t_ns, xy) of people walking straight lines through a 20 m square, sampled at ``hz``,
    each seen in a random part of the time, with 3 cm noise; rows in time order."""
    times = np.arange(0.0, seconds, 1.0 / hz)
    t_parts, xy_parts = [], []
    for _ in range(n_people):
        start = rng.uniform(0, 20, 2)
        heading = rng.uniform(-math.pi, math.pi)
        speed = rng.uniform(0.5, 1.5)
        a, b = np.sort(rng.integers(0, len(times), 2))
        ts = times[a : b + 1]
        d = speed * (ts - ts[0])
        xy = start + np.stack([d * math.cos(heading), d * math.sin(heading)], 1)
        t_parts.append(T0 + np.round(ts * S).astype(np.int64))
        xy_parts.append(xy + rng.normal(0, 0.03, xy.shape))
    t = np.concatenate(t_parts)
    xy = np.concatenate(xy_parts)
    order = np.argsort(t, kind="stable")
    return t[order], xy[order]


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_chunked_linking_equals_linking_at_once(seed: int) -> None:
    rng = np.random.default_rng(seed)
    t, xy = walkers(rng, 12, 60.0, 5.0)
    whole = link_tracks(t, xy).track_id
    frames = np.flatnonzero(np.r_[True, t[1:] != t[:-1]])
    cuts = np.sort(rng.choice(frames[1:], size=8, replace=False))
    linker = TrackLinker()
    bounds = zip(np.r_[0, cuts], np.r_[cuts, len(t)], strict=True)
    parts = [linker.link(t[a:b], xy[a:b]) for a, b in bounds]
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    assert linker.next_id == whole.max() + 1
    assert len(linker) <= linker.next_id  # only live tracks are kept


def test_linker_forgets_ended_tracks_and_takes_late_frames() -> None:
    cfg = LinkerConfig(max_gap_s=1.0)
    linker = TrackLinker(cfg)
    ids = [int(linker.link([T0 + k * S // 10], [[0.1 * k, 0.0]])[0]) for k in range(10)]
    assert set(ids) == {0}
    # a frame stamped before the last one (stamps jitter across chunks): gated with dt = 0
    late = linker.link([T0 + 85 * S // 100], [[0.9, 0.01]])
    assert late.tolist() == [0]
    np.testing.assert_allclose(linker.v[0], [1.0, 0.0], atol=0.2)  # velocity kept
    # 5 s later the track has ended: a new id, and the old track is no longer held
    again = linker.link([T0 + 6 * S], [[0.9, 0.0]])
    assert again.tolist() == [1]
    assert len(linker) == 1
    np.testing.assert_array_equal(linker.link([T0], [[np.nan, 0.0]]), [-1])
    with pytest.raises(InputError):
        linker.link([T0, T0], [[0.0, 0.0]])


def test_heading_sources_per_row() -> None:
    est = HeadingEstimator()
    b = est.estimate(
        [0, 0, 0, S, 0],
        [[0, 0, 0], [0, 0, 0], [5, 0, 0], [6, 0, 0], [9, 9, 0]],
        [[1, 0, 0], [np.nan] * 3, [np.nan] * 3, [np.nan] * 3, [np.nan] * 3],
        [np.nan, 0.5, np.nan, np.nan, np.nan],
        [-1, -1, 4, 4, -1],
    )
    names = [SOURCES[c] for c in est.sources]
    assert names == ["velocity", "pose_yaw", "none", "track", "none"]
    assert b.heading[3] == pytest.approx(0.0)


def pose_array(t_ns: int, xys: list[tuple[float, float]], topic: str = "/legs") -> RawMessage:
    """A PoseArray as leg detectors publish it: no ids, all-zero quaternions."""
    msg = {"header": header(0, 0, "laser"), "poses": [pose(x, y, 0, ZERO_Q) for x, y in xys]}
    return raw("geometry_msgs/msg/PoseArray", msg, 1, log_time_ns=t_ns, topic=topic)


def two_walkers(n: int = 40, topic: str = "/legs") -> list[RawMessage]:
    """Person A walks +x at 1.1 m/s, person B walks -y at 1.1 m/s, 10 Hz, 10 m apart."""
    return [
        pose_array(T0 + k * S // 10, [(0.11 * k, 0.0), (10.0, 5.0 - 0.11 * k)], topic)
        for k in range(n)
    ]


def test_feeder_links_id_less_detections_into_headings() -> None:
    counts = DetectionCounts()
    feeder = DetectionFeeder(None, "laser", counts)
    batch = feeder.decode(two_walkers())
    a = batch.xyz[:, 0] < 5
    assert counts.headings["pose_yaw"] == 0  # zero quaternions never give a heading
    assert counts.headings["linked"] + counts.headings["none"] == len(batch) == 80
    # 0.3 m (min_step) of walking before the first heading: 3 detections each
    assert counts.headings["none"] == 2 * 3
    known = np.isfinite(batch.heading)
    np.testing.assert_allclose(batch.heading[known & a], 0.0, atol=1e-9)
    np.testing.assert_allclose(batch.heading[known & ~a], -math.pi / 2, atol=1e-9)
    np.testing.assert_allclose(batch.speed[known], 1.1, rtol=1e-6)


def test_feeder_linking_carries_over_chunks() -> None:
    msgs = two_walkers()
    whole = DetectionFeeder(None, "laser", DetectionCounts()).decode(msgs)
    counts = DetectionCounts()
    feeder = DetectionFeeder(None, "laser", counts)
    parts = [feeder.decode(msgs[i : i + 7]) for i in range(0, len(msgs), 7)]
    np.testing.assert_array_equal(np.concatenate([p.heading for p in parts]), whole.heading)
    assert counts.headings["linked"] == 74
    assert feeder._linkers.shared["/legs"].next_id == 2  # two people, two tracks


def test_feeder_without_linking_leaves_id_less_detections_without_heading() -> None:
    counts = DetectionCounts()
    batch = DetectionFeeder(None, "laser", counts, linker=None).decode(two_walkers())
    assert np.isnan(batch.heading).all()
    assert counts.headings == {"none": 80}


def test_each_topic_links_on_its_own() -> None:
    """The same walker seen by two sensors (topics): one track per topic, not a track that
    jumps between them."""
    msgs = sorted(
        [*two_walkers(20, "/front/legs"), *two_walkers(20, "/rear/legs")],
        key=lambda m: m.log_time_ns,
    )
    feeder = DetectionFeeder(None, "laser", DetectionCounts())
    feeder.decode(msgs)
    assert {k: v.next_id for k, v in feeder._linkers.shared.items()} == {
        "/front/legs": 2,
        "/rear/legs": 2,
    }


def test_detections_with_ids_are_not_linked() -> None:
    msgs = [
        raw(
            "leg_tracker/msg/PersonArray",
            {"header": header(0, 0, "laser"), "people": [{"pose": pose(0.1 * k, 0, 0, ZERO_Q),
                                                          "id": 3}]},
            1,
            log_time_ns=T0 + k * S // 10,
        )
        for k in range(10)
    ]
    counts = DetectionCounts()
    feeder = DetectionFeeder(None, "laser", counts)
    feeder.decode(msgs)
    assert feeder._linkers.shared == {}
    assert counts.headings == {"none": 1, "track": 9}  # the tracker's own ids, differenced


def _oriented(k: int, q_of: Any) -> RawMessage:
    xys = [(0.11 * k, 0.0), (10.0, 5.0 - 0.11 * k)]
    msg = {"header": header(0, 0, "laser"),
           "poses": [pose(x, y, 0, q_of(i, k)) for i, (x, y) in enumerate(xys)]}
    return raw("geometry_msgs/msg/PoseArray", msg, 1, log_time_ns=T0 + k * S // 10)


def test_real_orientations_are_headings_and_need_no_linking() -> None:
    """Orientations that vary are the detector's own heading estimates: pose yaw, no
    linking (which costs per message what the decoding of the message costs many times)."""
    def q(i: int, k: int) -> tuple[float, ...]:
        a = 0.01 * k + (0.0 if i == 0 else 1.0)
        return (0.0, 0.0, math.sin(a / 2), math.cos(a / 2))

    counts = DetectionCounts()
    feeder = DetectionFeeder(None, "laser", counts)
    batch = feeder.decode([_oriented(k, q) for k in range(20)])
    assert counts.headings == {"pose_yaw": 40}
    assert feeder._linkers.shared == {}
    np.testing.assert_allclose(batch.heading[:2], [0.0, 1.0])


def test_orientations_that_never_vary_are_no_headings() -> None:
    """Every orientation left at the identity (or any one value): no yaw, so the detections
    are linked and their headings come from motion."""
    counts = DetectionCounts()
    feeder = DetectionFeeder(None, "laser", counts)
    batch = feeder.decode([_oriented(k, lambda i, k: (0.0, 0.0, 0.0, 1.0)) for k in range(40)])
    assert counts.headings == {"linked": 74, "none": 6}
    known = np.isfinite(batch.heading)
    np.testing.assert_allclose(batch.heading[known & (batch.xyz[:, 0] < 5)], 0.0, atol=1e-9)


def test_each_recording_whose_tracks_are_its_own_links_on_its_own() -> None:
    """Two robots recording at once on one topic (messages marked with their recording, as
    the merge of several logs marks them): with ``apart`` naming both, each has a linker of
    its own and the same walkers get the same headings; without, the topic's one linker."""
    from aion_cli.formats.raw import from_recording

    msgs = [
        from_recording(pose_array(T0 + k * S // 10, [xy], "/legs"), rec)
        for k in range(40)
        for rec, xy in ((1, (0.11 * k, 0.0)), (2, (10.0, 5.0 - 0.11 * k)))
    ]
    apart = DetectionFeeder(None, "laser", DetectionCounts(), apart=frozenset({1, 2}))
    batch = apart.decode(msgs)
    assert apart._linkers.shared == {}
    assert {k: v.next_id for k, v in apart._linkers.own.items()} == {
        ("/legs", 1): 1,
        ("/legs", 2): 1,
    }
    known = np.isfinite(batch.heading)
    a = batch.xyz[:, 0] < 5
    np.testing.assert_allclose(batch.heading[known & a], 0.0, atol=1e-9)
    np.testing.assert_allclose(batch.heading[known & ~a], -math.pi / 2, atol=1e-9)
    assert int(known.sum()) == 80 - 2 * 3  # as one robot's two walkers (above)
    shared = DetectionFeeder(None, "laser", DetectionCounts())
    np.testing.assert_array_equal(shared.decode(msgs).heading, batch.heading)
    assert list(shared._linkers.shared) == ["/legs"]
    assert shared._linkers.own == {}
