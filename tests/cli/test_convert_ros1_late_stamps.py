"""ROS 1 stamps count unsigned 32-bit seconds (to 2106): ``aion convert`` writes PoseArray
logs past 2038-01-19 03:14:07 UTC into a ``.bag`` or an ``mcap-ros1`` container. Before, such a
convert failed with "error: internal error: 'i' format requires ..." (the messages went
through rosbags, whose ``Time`` has signed seconds). A scene graph (``--graph``), which goes
through rosbags, was refused up front; rosbags' ROS 1 ``Time`` now has unsigned seconds
(:func:`formats.msgdefs.base_typestore`), so it is written too and the log builds."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from tests.cli.conftest import run, run_json

GRAPH = Path(__file__).resolve().parents[1] / "data" / "dsg" / "apartment_dsg.json"
T0_S = 2_208_988_800  # 2040-01-01 00:00:00 UTC: beyond 2**31 - 1 seconds
ROWS = [(T0_S + k, 7, 0.5 * k, -1.25, 0.75) for k in range(4)]  # one row a second


def _raw_messages(log: Path, topic: str) -> list[tuple[int, bytes]]:
    """(log time, serialized bytes) of ``topic``'s messages, read by the container's own
    library."""
    if log.suffix == ".bag":
        from rosbags.rosbag1 import Reader

        with Reader(log) as reader:
            return [(t, bytes(raw)) for c, t, raw in reader.messages() if c.topic == topic]
    from mcap.reader import make_reader

    with log.open("rb") as f:
        return [(m.log_time, bytes(m.data))
                for _, c, m in make_reader(f).iter_messages(topics=[topic])]


def _write_csv(path: Path) -> Path:
    lines = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    lines += [f"{t * 10**9},{i},{x},{y},{z},0.0,0.5" for t, i, x, y, z in ROWS]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize(("container", "suffix"), [("bag", ".bag"), ("mcap-ros1", ".mcap")])
def test_pose_arrays_past_2038_are_written_in_ros1_logs(
    container: str, suffix: str, tmp_path: Path
) -> None:
    """Each PoseArray's ROS 1 header (seq, sec, nsec as uint32, frame "map") holds the
    CSV's time and its pose the CSV's position; the "still observing" empty messages of an
    --observed span past 2038 are written too (count 0), the header seq counting them."""
    tracks = _write_csv(tmp_path / "late.csv")
    log = tmp_path / f"late{suffix}"
    span = f"{T0_S - 60}..{T0_S + 3}"  # marks at -60 s, -30 s and 0 s (before the rows)
    result = run("convert", tracks, "-o", log, "--container", container, "--message-type",
                 "geometry_msgs/msg/PoseArray", "--observed", span, "-q")
    assert result.exit_code == 0, result.stderr
    messages = _raw_messages(log, "/people_tracker/tracked_persons")
    headers = [struct.unpack_from("<IIII", raw) for _, raw in messages]
    frames = [raw[16 : 16 + h[3]] for (_, raw), h in zip(messages, headers, strict=True)]
    assert set(frames) == {b"map"}
    counts = [struct.unpack_from("<I", raw, 19)[0] for _, raw in messages]
    stamps = [sec * 10**9 + nsec for _, sec, nsec, _ in headers]
    assert [seq for seq, *_ in headers] == list(range(len(messages)))
    assert [t for t, _ in messages] == stamps
    empty = [s for s, c in zip(stamps, counts, strict=True) if c == 0]
    assert empty[:2] == [(T0_S - 60) * 10**9, (T0_S - 30) * 10**9]
    rows = [(s, raw) for (s, (_, raw)), c in zip(zip(stamps, messages, strict=True), counts,
                                                  strict=True) if c == 1]
    assert [s for s, _ in rows] == [t * 10**9 for t, *_ in ROWS]
    for (_, raw), (_, _, x, y, z) in zip(rows, ROWS, strict=True):
        assert struct.unpack_from("<3d", raw, 23) == (x, y, z)
        assert len(raw) == 23 + 56  # one pose: position and orientation, 7 float64s


@pytest.mark.parametrize(("container", "suffix"), [("bag", ".bag"), ("mcap-ros1", ".mcap")])
def test_a_scene_graph_past_2038_is_written_in_ros1_logs(
    container: str, suffix: str, tmp_path: Path
) -> None:
    """The DsgUpdate's ROS 1 header (seq, uint32 sec, nsec) holds the first row's time, and
    the log builds a map of the graph's places from 2040 (it was refused: "the tracks with a
    scene graph reach beyond 2038-01-19 03:14:07 UTC")."""

    tracks = _write_csv(tmp_path / "late.csv")
    log = tmp_path / f"late{suffix}"
    result = run("convert", tracks, "-o", log, "--container", container, "--graph", GRAPH,
                 "--message-type", "geometry_msgs/msg/PoseArray", "-q")
    assert result.exit_code == 0, result.stderr
    graphs = _raw_messages(log, "/hydra/backend/dsg")
    assert graphs
    seq, sec, nsec = struct.unpack_from("<III", graphs[0][1])
    assert (seq, sec, nsec) == (0, ROWS[0][0], 0)
    assert graphs[0][0] == ROWS[0][0] * 10**9
    report = run_json("build", log, "-o", tmp_path / "late.aion", "--format", "json", "-q")
    assert report["time_span"]["start_ns"] == ROWS[0][0] * 10**9
    assert report["graph"]["decoded"] == len(graphs)
    assert report["detections"]["used"] == len(ROWS)
