"""A convert's fast paths against the slow ones they replace: ``tracked_persons_many`` (the
messages built a chunk at a time) against the message-at-a-time ``tracked_persons_bytes``,
and with ``pose_records`` against rosbags' serialization of ``pose_array_message``; the
header seq it is given; ``DistinctIds`` against ``np.unique`` of all the ids."""

from __future__ import annotations

import struct
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.types import DetectionBatch
from aion_cli.formats import track_messages, tracks_log
from aion_cli.formats.track_types import DistinctIds

S = 1_000_000_000


def _batch(n: int, seed: int) -> DetectionBatch:
    """``n`` rows of made-up detections, some without heading or speed (unset covariances)."""
    rng = np.random.default_rng(seed)
    heading = rng.uniform(-np.pi, np.pi, n)
    heading[rng.random(n) < 0.3] = np.nan
    speed = rng.uniform(0, 2, n)
    speed[rng.random(n) < 0.3] = np.nan
    return DetectionBatch.from_arrays(
        t_ns=np.zeros(n, np.int64),
        xyz=rng.normal(size=(n, 3)),
        heading=heading,
        speed=speed,
        track_id=rng.integers(0, 2**40, n),
    )


def _one_at_a_time(
    records: np.ndarray, bounds: list[int], stamps: list[int], seqs: list[int], frame: str,
    cdr: bool,
) -> list[bytes]:
    return [
        track_messages.tracked_persons_bytes(records[a:b], t, frame, cdr, q)
        for a, b, t, q in zip(bounds[:-1], bounds[1:], stamps, seqs, strict=True)
    ]


@settings(max_examples=150, deadline=None)
@given(
    sizes=st.lists(st.integers(0, 4), min_size=0, max_size=8),
    frame=st.text(max_size=9),
    cdr=st.booleans(),
    first_s=st.integers(0, 2**32 - 50),
    first_seq=st.integers(0, 2**32 - 20),
    seed=st.integers(0, 2**16),
)
def test_many_equals_one_at_a_time(
    sizes: list[int], frame: str, cdr: bool, first_s: int, first_seq: int, seed: int
) -> None:
    """Every message's bytes, for every frame length (CDR pads after the string), empty
    messages, and stamps / seqs up to and past what the header holds (ROS 2 seconds end at
    2^31 - 1, where both refuse with ``struct.error``)."""
    bounds = np.concatenate([[0], np.cumsum(sizes)]).astype(int).tolist()
    records = track_messages.tracked_person_records(_batch(bounds[-1], seed), cdr, first_id=3)
    stamps = [(first_s + 7 * i) * S + i * 999_999 for i in range(len(sizes))]
    seqs = [first_seq + 2 * i for i in range(len(sizes))]
    try:
        expected = _one_at_a_time(records, bounds, stamps, seqs, frame, cdr)
    except struct.error:
        with pytest.raises(struct.error):
            list(track_messages.tracked_persons_many(
                records, bounds, np.array(stamps), np.array(seqs), frame, cdr))
        return
    got = list(track_messages.tracked_persons_many(
        records, bounds, np.array(stamps), np.array(seqs), frame, cdr))
    assert got == expected


@pytest.mark.parametrize("cdr", [True, False])
def test_many_known_header_bytes(cdr: bool) -> None:
    """One message of one record, its header spelt out by hand."""
    records = track_messages.tracked_person_records(_batch(1, 0), cdr)
    (raw,) = track_messages.tracked_persons_many(
        records, [0, 1], np.array([5 * S + 6]), np.array([9]), "ab", cdr)
    if cdr:  # encapsulation; sec 5, nsec 6, "ab\0" (3), pad to 4, count 1, pad to 8
        head = b"\x00\x01\x00\x00" + struct.pack("<iII", 5, 6, 3) + b"ab\x00" + b"\x00" \
            + struct.pack("<I", 1) + b"\x00" * 4
    else:  # seq 9, sec 5, nsec 6, "ab", count 1
        head = struct.pack("<IIII", 9, 5, 6, 2) + b"ab" + struct.pack("<I", 1)
    assert raw == head + records.tobytes()


def test_ros1_header_seq_counts_the_marker_messages(tmp_path: Path) -> None:
    """A ROS 1 header's seq numbers every detection and marker message in log order, also
    where the markers fall between detection messages: detections at 10, 50 and 100 s and
    an observed span 0..70 s (markers at 0, 30, 60 and 70 - 1 ns) make the messages
    0 (marker), 10 (det), 30, 50 (det), 60, 70 - 1 ns, 100 (det), seq 0..6."""
    from mcap.reader import make_reader

    batch = DetectionBatch.from_arrays(
        t_ns=[10 * S, 50 * S, 50 * S, 100 * S],
        xyz=[[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]],
        track_id=[1, 1, 2, 1],
    )
    out = tmp_path / "seq.mcap"
    tracks_log.tracks_to_log(batch, out, container="mcap-ros1", observed=[(0, 70 * S)])
    with out.open("rb") as fh:
        got = [
            (m.log_time, *struct.unpack_from("<IIII", m.data), m.data)
            for _, ch, m in make_reader(fh).iter_messages()
            if ch.topic == "/people_tracker/tracked_persons"
        ]
    times = [0, 10 * S, 30 * S, 50 * S, 60 * S, 70 * S - 1, 100 * S]
    assert [g[0] for g in got] == times
    assert [g[1] for g in got] == list(range(7))  # seq
    assert [(g[2], g[3]) for g in got] == [divmod(t, S) for t in times]
    counts = [struct.unpack_from("<I", d, 16 + g[4])[0] for *g, d in got]
    assert counts == [0, 1, 0, 2, 0, 0, 1]


@settings(max_examples=150, deadline=None)
@given(st.lists(st.lists(st.integers(-5, 40), max_size=30), max_size=12), st.booleans())
def test_distinct_ids_counts_as_unique_of_everything(
    batches: list[list[int]], ask_between: bool
) -> None:
    """However the ids fall into batches (repeats within and across them, empty ones), the
    count is that of the distinct ids of all of them, also when asked between batches."""
    ids = DistinctIds()
    seen: set[int] = set()
    for batch in batches:
        ids.add(np.array(batch, dtype=np.int64))
        seen.update(batch)
        if ask_between:
            assert len(ids) == len(seen)
    assert len(ids) == len(seen) == len(np.unique([i for b in batches for i in b]))


def test_distinct_ids_merge_as_they_go() -> None:
    """Ids wait in batches only while they are fewer than those merged: 100 batches of the
    same ten ids never hold more than about twice ten."""
    ids = DistinctIds()
    for _ in range(100):
        ids.add(np.arange(10, dtype=np.int64))
        assert ids.waiting + len(ids.merged) <= 2 * 10
    assert len(ids) == 10


@settings(max_examples=60, deadline=None)
@given(
    sizes=st.lists(st.integers(0, 4), min_size=1, max_size=5),
    frame=st.sampled_from(["", "map", "odom_x", "base_link"]),
    container=st.sampled_from(["mcap", "mcap-ros1"]),
    first_s=st.integers(0, 2**31 - 50),
    seed=st.integers(0, 2**16),
)
def test_pose_arrays_equal_rosbags_serialization(
    sizes: list[int], frame: str, container: str, first_s: int, seed: int
) -> None:
    """PoseArray messages from ``pose_records`` are the bytes rosbags serializes from the
    dicts ``pose_array_message`` builds (what a convert wrote before), headings unknown
    (zero quaternion) or known, in ROS 2 (CDR) and ROS 1 layout with its header seq."""
    from aion_cli.formats.writers import LogWriter

    batch = _batch(sum(sizes), seed)
    bounds = np.concatenate([[0], np.cumsum(sizes)]).astype(int).tolist()
    stamps = [(first_s + 3 * i) * S + 17 * i for i in range(len(sizes))]
    seqs = [5 + i for i in range(len(sizes))]
    quat_a, _, known_h, _ = track_messages.orientation_velocity(batch)
    quat = np.where(known_h[:, None], quat_a, 0.0).tolist()
    xyz = batch.xyz.tolist()
    with tempfile.TemporaryDirectory() as tmp, LogWriter(Path(tmp) / "w.mcap", container) as w:
        cdr = w.ros_version == 2
        expected = []
        for a, b, t, q in zip(bounds[:-1], bounds[1:], stamps, seqs, strict=True):
            msg = track_messages.pose_array_message(t, xyz[a:b], quat[a:b], frame)
            if not cdr:
                msg["header"]["seq"] = q
            expected.append(w.serialize(tracks_log.POSE_ARRAY, msg))
    got = track_messages.tracked_persons_many(
        track_messages.pose_records(batch), bounds, np.array(stamps), np.array(seqs), frame, cdr)
    assert list(got) == expected
