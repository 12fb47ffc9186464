"""The sample of a build's detections that tells one recording in two files from two
recordings (:mod:`aion_cli.engine.detection_sketch`): a function of the detections alone,
bounded, and alike exactly where the detections are the same."""

from __future__ import annotations

import base64

import numpy as np
import pytest

from aion_cli.engine.detection_sketch import (
    SKETCH_SIZE,
    DetectionSketch,
    alike,
    batch_alike,
    one_recording,
)

N = 50_000
T0 = 1_795_420_800 * 10**9  # 2026-11-23 08:00 UTC


def _detections(seed: int, t0: int = T0) -> tuple[np.ndarray, np.ndarray]:
    """``N`` detections 0.1 s apart (a few people at each stamp) at random positions."""
    rng = np.random.default_rng(seed)
    t = t0 + np.sort(rng.integers(0, N // 4, N)) * 100_000_000
    return t.astype(np.int64), rng.uniform(-20, 20, (N, 3))


def _sketch(t: np.ndarray, xyz: np.ndarray, batch: int = 1000) -> DetectionSketch:
    s = DetectionSketch()
    for k in range(0, len(t), batch):
        s.add(t[k : k + batch], xyz[k : k + batch])
    return s


def test_the_sample_depends_on_the_detections_not_on_their_batches_or_order() -> None:
    t, xyz = _detections(1)
    whole = _sketch(t, xyz, batch=N)
    order = np.random.default_rng(0).permutation(N)
    shuffled = _sketch(t[order], xyz[order], batch=777)
    halves = _sketch(t[: N // 2], xyz[: N // 2])
    halves.merge(_sketch(t[N // 2 :], xyz[N // 2 :]))
    for other in (shuffled, halves):
        assert other.level == whole.level
        assert other.h.tobytes() == whole.h.tobytes()
        assert other.t_ns.tobytes() == whole.t_ns.tobytes()
        assert (other.detections, other.first_ns, other.last_ns) == (N, t.min(), t.max())
    # at most SKETCH_SIZE kept, more than half of it: each level halves what is kept
    assert SKETCH_SIZE // 2 < len(whole) <= SKETCH_SIZE
    assert whole.level > 0
    assert (whole.h >> np.uint64(64 - whole.level) == 0).all()


def test_copies_cut_and_rounded_are_one_recording_others_are_not() -> None:
    t, xyz = _detections(1)
    whole = _sketch(t, xyz)
    tenth = slice(N // 2, N // 2 + N // 10)  # a copy cut at another start
    cut = _sketch(t[tenth], xyz[tenth])
    rounded = _sketch(t, xyz.astype(np.float32).astype(np.float64))  # float32 positions
    for copy in (cut, rounded):
        found = one_recording(whole, copy)
        assert found is not None
        assert found[0] == found[1] >= 2
        assert one_recording(copy, whole) == found
    # two robots at the same stamps seeing other people; the same walks a day later;
    # the same people 1 cm apart (another sensor)
    _, xyz2 = _detections(2)
    others = [
        _sketch(t, xyz2),
        _sketch(t + 86_400 * 10**9, xyz),
        _sketch(t, xyz + 0.01),
    ]
    assert [alike(whole, o)[0] for o in others] == [0, 0, 0]
    assert alike(whole, others[1])[1] == 0  # no common time: nothing compared
    assert all(one_recording(whole, o) is None for o in others)


def test_two_files_of_one_recording_that_share_a_fifth_of_their_time_do_not_repeat() -> None:
    """Two files of one recording that overlap by minutes hold the same detections then
    (every sample of that time alike), but neither repeats the other: their people count
    twice in that time only, as when one build is given both."""
    t, xyz = _detections(5)
    early, late = slice(0, 6 * N // 10), slice(4 * N // 10, N)
    a, b = _sketch(t[early], xyz[early]), _sketch(t[late], xyz[late])
    same, compared = alike(a, b)
    assert same == compared > 0
    assert one_recording(a, b) is None
    # one file inside the other: a repeat, whichever is given first
    inside = slice(N // 10, 5 * N // 10)
    c = _sketch(t[inside], xyz[inside])
    assert one_recording(a, c) == one_recording(c, a) is not None


def test_a_stored_sketch_reads_back_and_a_damaged_one_is_none() -> None:
    t, xyz = _detections(3)
    s = _sketch(t, xyz)
    back = DetectionSketch.from_dict(s.to_dict())
    assert back is not None
    assert back.to_dict() == s.to_dict()
    assert alike(s, back) == (len(s), len(s))
    stored = s.to_dict()
    damaged = [
        {k: v for k, v in stored.items() if k != "samples"},
        stored | {"samples": "not base64!"},
        stored | {"samples": base64.b64encode(b"123").decode()},  # not 16-byte pairs
        stored | {"level": 65},
        stored | {"first_ns": stored["last_ns"] + 1},
        stored | {"first_ns": None},
        "a string",
    ]
    assert [DetectionSketch.from_dict(d) for d in damaged] == [None] * len(damaged)


def test_rows_without_a_finite_position_are_left_out() -> None:
    s = DetectionSketch()
    s.add(np.array([T0, T0 + 1, T0 + 2]), np.array([[0, 0, 0], [np.nan, 0, 0], [np.inf, 1, 1]]))
    assert (s.detections, len(s), s.first_ns, s.last_ns) == (1, 1, T0, T0)
    s.add(np.zeros(0, np.int64), np.zeros((0, 3)))
    assert s.detections == 1


@pytest.mark.parametrize("shift_m", [0.0, 0.5])
def test_a_batch_is_compared_with_the_samples_in_its_time(shift_m: float) -> None:
    t, xyz = _detections(4)
    s = _sketch(t, xyz)
    part = slice(10_000, 30_000)
    same, compared = batch_alike(s, t[part], xyz[part] + shift_m)
    inside = int(((s.t_ns >= t[part].min()) & (s.t_ns <= t[part].max())).sum())
    assert compared == inside > 0
    assert same == (inside if shift_m == 0 else 0)
