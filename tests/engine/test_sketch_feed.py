"""A :class:`~aion_cli.engine.detection_sketch.SketchFeed` gives the sketch that adding every
batch at once gives (the build hashes a few thousand detections at a time, issue 15),
including which stamp a hash keeps when detections repeat within a microsecond."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.detection_sketch import DetectionSketch, SketchFeed

T0 = 1_795_420_800 * 10**9  # 2026-11-23 08:00 UTC


def _batches(seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Batches of 0..300 detections; a third of the rows repeat an earlier row's position
    and microsecond with other nanoseconds (the same hash, another stamp), a few rows have
    no finite position, one batch is empty."""
    rng = np.random.default_rng(seed)
    out = []
    t_all, p_all = np.zeros(0, np.int64), np.zeros((0, 3))
    for k in range(120):
        n = 0 if k == 7 else int(rng.integers(1, 300))
        t = T0 + k * 10**9 + rng.integers(0, 10**9, n)
        p = rng.uniform(-20, 20, (n, 3))
        again = rng.random(n) < 0.33
        if len(t_all) and again.any():
            src = rng.integers(0, len(t_all), int(again.sum()))
            t[again] = (t_all[src] // 1000) * 1000 + rng.integers(0, 1000, len(src))
            p[again] = p_all[src]
        p[rng.random(n) < 0.02, 1] = np.nan
        out.append((t.astype(np.int64), p))
        t_all, p_all = np.concatenate([t_all, t]), np.concatenate([p_all, p])
    return out


def _fields(s: DetectionSketch) -> tuple[object, ...]:
    return (s.level, s.h.tobytes(), s.t_ns.tobytes(), s.detections, s.first_ns, s.last_ns)


@pytest.mark.parametrize("rows", [1, 50, 1000, 4096, 10**9])
def test_the_feed_gives_the_sketch_of_its_batches_added_one_by_one(rows: int) -> None:
    batches = _batches(3)
    direct = DetectionSketch()
    for t, p in batches:
        direct.add(t, p)
    # the repeats are there: fewer distinct hashes kept than rows sampled, stamps differing
    assert direct.level > 0
    fed = DetectionSketch()
    feed = SketchFeed(fed, rows)
    for t, p in batches:
        feed.add(t, p)
    feed.flush()
    assert _fields(fed) == _fields(direct)
    feed.flush()  # nothing held: no change
    assert _fields(fed) == _fields(direct)


def test_the_feed_holds_rows_until_it_has_enough_or_is_flushed() -> None:
    sketch = DetectionSketch()
    feed = SketchFeed(sketch, rows=100)
    t = T0 + np.arange(60, dtype=np.int64) * 10**6
    p = np.random.default_rng(0).uniform(-5, 5, (60, 3))
    feed.add(t, p)
    assert (sketch.detections, sketch.first_ns) == (0, None)
    feed.add(t + 10**9, p)  # 120 rows held: hashed
    assert (sketch.detections, sketch.first_ns, sketch.last_ns) == (120, T0, int(t[-1]) + 10**9)
    feed.add(t + 2 * 10**9, p)
    assert sketch.detections == 120
    feed.flush()
    assert sketch.detections == 180
