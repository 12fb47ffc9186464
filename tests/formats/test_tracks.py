"""Track files (canonical, ATC, THÖR, ETH/UCY) and tracks -> log conversion."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from aion_cli.engine.types import DetectionBatch
from aion_cli.errors import InputError
from aion_cli.formats import observed_marks, track_csv, track_messages, tracks_log
from aion_cli.formats import tracks as ft
from aion_cli.formats.detections.frame import FrameDetections
from tests.shared_data import SHARED_DATA, needs, real_path

DATA = SHARED_DATA
ATC = real_path("atc", "atc-1024-9_test.csv")
THOR = real_path("thor", "thor1-exp-1-run-2.csv")
THOR3 = real_path("thor", "thor3-exp-3-run-2.csv")
S = 1_000_000_000


def _csv_rows(path: Path) -> list[list[str]]:
    with path.open() as fh:
        return [row for row in csv.reader(fh) if row]


# ----------------------------------------------------------------------------- real files


@needs(ATC, "the ATC excerpt")
def test_atc_real_file() -> None:
    rows = _csv_rows(ATC)
    batch = ft.read_tracks(ATC, "atc")
    assert len(batch) == len(rows) == 2504
    times = [float(r[0]) for r in rows]
    assert batch.t_ns[0] == round(min(times) * 1000) * 1_000_000
    assert batch.t_ns[-1] == round(max(times) * 1000) * 1_000_000
    assert (np.diff(batch.t_ns) >= 0).all()
    assert batch.t_ns[0] == 1351038020969 * 1_000_000  # 2012-10-24 00:20:20.969 UTC
    assert (np.abs(batch.heading) <= np.pi).all()
    assert set(batch.track_id.tolist()) == {int(r[1]) for r in rows}
    np.testing.assert_array_equal(batch.xyz[:, 2], 0)
    # every file row is in the batch with its own values (order-independent)
    want = sorted((round(float(r[0]) * 1000), int(r[1]), float(r[2]), float(r[3])) for r in rows)
    got = sorted(
        zip(
            (batch.t_ns // 1_000_000).tolist(),
            batch.track_id.tolist(),
            batch.xyz[:, 0].tolist(),
            batch.xyz[:, 1].tolist(),
            strict=True,
        )
    )
    assert got == want


@needs(THOR3, "the THÖR files")
@needs(THOR, "the THÖR files")
@pytest.mark.parametrize("path", [THOR, THOR3])
def test_thor_real_files_with_start_offset(path: Path) -> None:
    rows = _csv_rows(path)
    start = 1_600_000_000 * S
    batch = ft.read_tracks(path, "thor", start_ns=start)
    assert len(batch) == len(rows)
    assert batch.t_ns[0] == start + round(min(float(r[0]) for r in rows) * 1e6) * 1000
    assert batch.t_ns[-1] - batch.t_ns[0] < 300 * S  # a ~4 minute run
    standing = np.array([float(r[4]) == 0.0 and float(r[5]) == 0.0 for r in rows])
    # a zero speed with a zero angle is no direction: NaN there (as many rows as the file
    # has), every other heading an angle
    assert int(np.isnan(batch.heading).sum()) == int(standing.sum())
    assert (np.abs(batch.heading[np.isfinite(batch.heading)]) <= np.pi).all()
    assert np.isclose(batch.speed.sum(), sum(float(r[4]) for r in rows))


# ----------------------------------------------------------------------------- canonical


def test_canonical_round_trip(tmp_path: Path) -> None:
    batch = DetectionBatch.from_arrays(
        t_ns=[1_700_000_000_123_456_789, 1_700_000_000_000_000_001, 5],
        xyz=[[1.25, -2.5, 0.0], [1e4, 3.000001, 1.5], [0, 0, 0]],
        heading=[0.5, np.nan, -3.1],
        speed=[1.2, np.nan, 0.0],
        track_id=[7, -1, 2**40],
    )
    path = tmp_path / "tracks.csv"
    track_csv.write_canonical_csv(batch, path)
    assert path.read_text().splitlines()[0] == track_csv.CANONICAL_HEADER
    back = ft.read_tracks(path)
    order = np.argsort(batch.t_ns)
    np.testing.assert_array_equal(back.t_ns, batch.t_ns[order])  # exact int64 ns
    np.testing.assert_array_equal(back.track_id, batch.track_id[order])
    np.testing.assert_allclose(back.xyz, batch.xyz[order], atol=1e-6)
    np.testing.assert_allclose(back.heading, batch.heading[order], atol=1e-9)
    np.testing.assert_allclose(back.speed, batch.speed[order], atol=1e-6)
    assert np.isnan(back.heading[1])
    # a spreadsheet's UTF-8 byte-order mark and CRLF line ends are accepted
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + path.read_bytes().replace(b"\n", b"\r\n"))
    np.testing.assert_array_equal(ft.read_tracks(bom).t_ns, back.t_ns)
    atc_bom = tmp_path / "atc_bom.csv"
    atc_bom.write_bytes(b"\xef\xbb\xbf1.5,3,0.1,0.2,0.3,0.4\r\n")
    assert ft.read_tracks(atc_bom, "atc").t_ns.tolist() == [1_500_000_000]


# ----------------------------------------------------------------------------- ETH / UCY


def test_eth_straight_walk_heading_and_speed(tmp_path: Path) -> None:
    lines = []
    h1 = math.radians(30)
    for k in range(6):  # ped 1: 1.2 m/s at 30°, sampled every 10 frames (0.4 s)
        d = 1.2 * 0.4 * k
        lines.append(
            f"{100 + 10 * k:.1f}\t1.0\t{2 + d * math.cos(h1):.6f}\t{1 + d * math.sin(h1):.6f}"
        )
    for k in range(4):  # ped 2: 0.5 m/s due west (heading π), interleaved frames
        lines.append(f"{120 + 10 * k:.1f}\t2.0\t{-0.2 * k:.6f}\t5.000000")
    lines.append("300.0\t3.0\t0.0\t0.0")  # ped 3: one sample, heading unknown
    path = tmp_path / "eth.txt"
    path.write_text("\n".join(lines) + "\n")
    batch = ft.read_tracks(path, "eth", start_ns=10 * S)
    assert len(batch) == 11
    one = batch.track_id == 1
    assert batch.t_ns[one].tolist() == [10 * S + (100 + 10 * k) * 40_000_000 for k in range(6)]
    np.testing.assert_allclose(batch.heading[one], h1, atol=1e-5)
    np.testing.assert_allclose(batch.speed[one], 1.2, atol=1e-5)
    two = batch.track_id == 2
    np.testing.assert_allclose(np.abs(batch.heading[two]), np.pi, atol=1e-9)
    np.testing.assert_allclose(batch.speed[two], 0.5, atol=1e-9)
    three = batch.track_id == 3
    assert np.isnan(batch.heading[three]).all()
    assert np.isnan(batch.speed[three]).all()


def test_finite_difference_central_on_curve() -> None:
    # a quarter circle at constant speed: central differences give the chord direction
    t = np.arange(3, dtype=np.int64) * S
    xy = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])
    heading, speed = track_csv.finite_difference(t, np.zeros(3, np.int64), xy)
    np.testing.assert_allclose(heading, [3 * np.pi / 4, np.pi, -3 * np.pi / 4])
    np.testing.assert_allclose(speed, [math.sqrt(2), 1.0, math.sqrt(2)])


# ----------------------------------------------------------------------------- bad files


def _read_log(path: Path) -> list[tuple[str, int, object]]:
    from rosbags.highlevel import AnyReader

    out = []
    with AnyReader([path]) as reader:
        for conn, t, raw in reader.messages():
            out.append((conn.topic, t, reader.deserialize(raw, conn.msgtype)))
    return out


@needs(real_path("dsg", "apartment_dsg.json"), "the apartment scene graph")
@needs(THOR, "the THÖR file")
def test_tracks_to_log_round_trip_with_graph(tmp_path: Path) -> None:
    batch = ft.read_tracks(THOR, "thor", start_ns=1_600_000_000 * S)
    out = tmp_path / "thor.mcap"
    graph = real_path("dsg", "apartment_dsg.json")
    summary = tracks_log.tracks_to_log(batch, out, graph_file=graph, graph_period_s=60.0)
    distinct = np.unique(batch.t_ns)
    assert summary.detection_messages == len(distinct)
    span_s = (batch.t_ns[-1] - batch.t_ns[0]) / 1e9
    assert summary.graph_messages == math.floor(span_s / 60.0) + 1
    msgs = _read_log(out)
    people = [(t, m) for topic, t, m in msgs if topic == "/people_tracker/tracked_persons"]
    graphs = [(t, m) for topic, t, m in msgs if topic == "/hydra/backend/dsg"]
    assert len(people) == len(distinct)
    assert len(graphs) == summary.graph_messages
    assert graphs[0][0] == batch.t_ns[0]  # the graph comes first
    assert msgs[0][0] == "/hydra/backend/dsg"
    rows_t, rows_xyz, rows_v, rows_id = [], [], [], []
    for t, m in people:
        stamp = m.header.stamp.sec * S + m.header.stamp.nanosec
        assert stamp == t
        assert m.header.frame_id == "map"
        for tr in m.tracks:
            p = tr.pose.pose.position
            v = tr.twist.twist.linear
            rows_t.append(t)
            rows_xyz.append((p.x, p.y, p.z))
            rows_v.append((v.x, v.y))
            rows_id.append(tr.track_id)
    order = np.lexsort((batch.track_id, batch.t_ns))
    got = np.lexsort((np.array(rows_id), np.array(rows_t)))
    assert np.array(rows_t)[got].tolist() == batch.t_ns[order].tolist()
    assert np.array(rows_id)[got].tolist() == batch.track_id[order].tolist()
    np.testing.assert_allclose(np.array(rows_xyz)[got], batch.xyz[order])
    vel = np.stack([np.cos(batch.heading), np.sin(batch.heading)], 1) * batch.speed[:, None]
    vel[~np.isfinite(batch.heading)] = 0.0  # no direction: written as zero, flagged unset
    np.testing.assert_allclose(np.array(rows_v)[got], vel[order], atol=1e-12)

    from aion_cli.formats.dsg import decode_dsg_update

    payload = graphs[0][1].layer_contents
    snap = decode_dsg_update(np.asarray(payload, dtype=np.uint8), int(graphs[0][0]))
    assert len(snap.places) == 185
    assert len(snap.edges) == 396


def test_tracks_to_log_pose_array_grouped_and_unknown_heading(tmp_path: Path) -> None:
    batch = DetectionBatch.from_arrays(
        t_ns=[0, 30_000_000, 120_000_000, 130_000_000],
        xyz=[[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]],
        heading=[np.pi / 2, np.nan, 0.0, -np.pi / 2],
        speed=[1.0, np.nan, 0.5, 0.5],
    )
    out = tmp_path / "p.bag"
    summary = tracks_log.tracks_to_log(
        batch, out, container="bag", msgtype="geometry_msgs/PoseArray", group_ns=100_000_000
    )
    assert summary.detection_messages == 2
    assert summary.graph_messages == 0
    msgs = _read_log(out)
    assert [t for _, t, _ in msgs] == [0, 120_000_000]
    first = msgs[0][2]
    assert [p.position.x for p in first.poses] == [0.0, 1.0]
    q = first.poses[0].orientation
    assert math.isclose(2 * math.atan2(q.z, q.w), np.pi / 2)
    # no heading: the all-zero "unset" quaternion, which a build never takes for a heading
    # (the identity it was would read as walking along +x beside the others' yaws)
    o = first.poses[1].orientation
    assert (o.x, o.y, o.z, o.w) == (0.0, 0.0, 0.0, 0.0)


def test_tracks_to_log_spencer_marks_unknown_velocity(tmp_path: Path) -> None:
    batch = DetectionBatch.from_arrays(
        t_ns=[5, 5],
        xyz=[[0, 0, 0], [1, 1, 0]],
        heading=[np.nan, 1.0],
        speed=[np.nan, 2.0],
        track_id=[1, 2],
    )
    out = tmp_path / "s.mcap"
    tracks_log.tracks_to_log(batch, out)
    ((_, _, msg),) = _read_log(out)
    unknown, known = sorted(msg.tracks, key=lambda tr: tr.track_id)
    assert unknown.twist.covariance[0] > 99999
    assert unknown.pose.covariance[35] > 99999
    assert known.twist.covariance[0] == 0
    assert math.isclose(known.twist.twist.linear.x, 2 * math.cos(1.0))


def test_tracks_to_log_errors(tmp_path: Path) -> None:
    no_ids = DetectionBatch.from_arrays([1], [[0, 0, 0]])
    with pytest.raises(InputError, match="track ids"):
        tracks_log.tracks_to_log(no_ids, tmp_path / "a.mcap")
    with pytest.raises(InputError, match="no detections"):
        tracks_log.tracks_to_log(DetectionBatch.empty(), tmp_path / "b.mcap")
    with pytest.raises(InputError, match="cannot write tracks"):
        tracks_log.tracks_to_log(no_ids, tmp_path / "c.mcap", msgtype="people_msgs/People")
    with pytest.raises(InputError, match="scene-graph file not found"):
        tracks_log.tracks_to_log(
            DetectionBatch.from_arrays([1], [[0, 0, 0]], track_id=[1]),
            tmp_path / "d.mcap",
            graph_file=tmp_path / "nope.json",
        )


def _cov(unset_idx: list[int]) -> list[float]:
    return [1e6 if k in unset_idx else 0.0 for k in range(36)]


@pytest.mark.parametrize("container", ["mcap", "bag"])
def test_vectorized_tracked_persons_bytes_equal_writer_serialization(
    tmp_path: Path, container: str
) -> None:
    """The numpy-built wire bytes equal what rosbags serializes from the equivalent dict."""
    from aion_cli.formats.writers import LogWriter

    batch = DetectionBatch.from_arrays(
        t_ns=[7 * S + 5, 7 * S + 5, 7 * S + 5],
        xyz=[[1.5, -2.0, 0.25], [3.0, 4.0, 0.0], [0.0, 0.0, 1.0]],
        heading=[0.3, np.nan, -2.0],
        speed=[1.1, 0.0, np.nan],
        track_id=[11, 2**40, 0],
    )
    for frame in ("map", "odom_x"):  # two string lengths: different CDR padding
        with LogWriter(tmp_path / f"w-{frame}.{container}", container) as writer:
            cdr = writer.ros_version == 2
            records = track_messages.tracked_person_records(batch, cdr)
            raw = track_messages.tracked_persons_bytes(
                records, int(batch.t_ns[0]), frame, cdr, seq=4
            )
            tracks = []
            for i in range(3):
                h, s = batch.heading[i], batch.speed[i]
                known_h, known_v = not np.isnan(h), not (np.isnan(h) or np.isnan(s))
                hh = h if known_h else 0.0
                ss = s if known_v else 0.0
                x, y, z = batch.xyz[i]
                tracks.append(
                    {
                        "track_id": int(batch.track_id[i]),
                        "is_matched": True,
                        "detection_id": i,
                        "pose": {
                            "pose": {
                                "position": {"x": x, "y": y, "z": z},
                                "orientation": {"z": math.sin(hh / 2), "w": math.cos(hh / 2)},
                            },
                            "covariance": _cov([] if known_h else [35]),
                        },
                        "twist": {
                            "twist": {"linear": {"x": ss * math.cos(hh), "y": ss * math.sin(hh)}},
                            "covariance": _cov([] if known_v else [0, 7, 14]),
                        },
                    }
                )
            header = {"stamp": {"sec": 7, "nanosec": 5}, "frame_id": frame, "seq": 4}
            if cdr:
                del header["seq"]
            want = writer.serialize(
                tracks_log.SPENCER_TRACKED, {"header": header, "tracks": tracks}
            )
            assert raw == want


@needs(THOR3, "the THÖR file")
def test_tracks_to_log_ros1_bag_spencer(tmp_path: Path) -> None:
    batch = ft.read_tracks(THOR3, "thor")
    out = tmp_path / "t.bag"
    summary = tracks_log.tracks_to_log(batch, out, container="bag")
    msgs = _read_log(out)
    assert len(msgs) == summary.detection_messages == len(np.unique(batch.t_ns))
    xyz = np.array(
        [(tr.pose.pose.position.x, tr.pose.pose.position.y) for _, _, m in msgs for tr in m.tracks]
    )
    np.testing.assert_allclose(np.sort(xyz[:, 0]), np.sort(batch.xyz[:, 0]))
    assert [m.header.seq for _, _, m in msgs[:3]] == [0, 1, 2]


# ----------------------------------------------------------------------------- observed spans


def test_observed_stamps_every_interval_and_the_last_instant() -> None:
    spans = [(90 * S, 100 * S), (0, 95 * S), (200 * S, 200 * S + 1)]  # overlapping, unsorted
    stamps = observed_marks.observed_stamps(spans, 30 * S)
    assert stamps.tolist() == [0, 30 * S, 60 * S, 90 * S, 100 * S - 1, 200 * S]
    assert observed_marks.observed_stamps([]).tolist() == []
    assert observed_marks.OBSERVED_INTERVAL_NS == 30 * S
    with pytest.raises(InputError, match="ends before it starts"):
        observed_marks.observed_stamps([(5, 5)])
    with pytest.raises(InputError, match="interval"):
        observed_marks.observed_stamps([(0, S)], 0)


def _log_messages(path: Path) -> tuple[list[int], FrameDetections, npt.NDArray[np.int64]]:
    """Log times of the detection topic's messages, the decoded detections (adapter) and
    windows recorded (a ROS 1 bag's latched /aion/observed metadata topic left out)."""
    from aion_cli.formats.detections import adapter_for
    from aion_cli.formats.logs import open_logs

    with open_logs([path]) as logs:
        msgs = [m for m in logs.messages() if m.topic != "/aion/observed"]
        adapter = adapter_for(msgs[0].msgtype)
        assert adapter is not None
        frames = adapter.decode(msgs)
        windows = logs.recorded_windows(600 * S)
    return [m.log_time_ns for m in msgs], frames, windows


@pytest.mark.parametrize(
    ("container", "msgtype"),
    [
        ("mcap", tracks_log.SPENCER_TRACKED),
        ("bag", tracks_log.POSE_ARRAY),
        ("mcap", tracks_log.POSE_ARRAY),
    ],
)
def test_tracks_to_log_marks_observed_spans(tmp_path: Path, container: str, msgtype: str) -> None:
    t0 = 1_700_000_000 * S
    batch = DetectionBatch.from_arrays(
        t_ns=[t0 + 5 * S, t0 + 6 * S, t0 + 6 * S, t0 + 7300 * S],
        xyz=np.array([[1, 2, 0], [1.5, 2, 0], [4, 4, 0], [9, 9, 0]], dtype=float),
        heading=[0.0, 0.0, 1.0, 2.0],
        speed=[1.0, 1.0, 0.5, 0.5],
        track_id=[1, 1, 2, 3],
    )
    spans = [(t0 - 1800 * S, t0 + 1800 * S), (t0 + 7200 * S, t0 + 7200 * S + 3599 * S)]
    out = tmp_path / f"o.{container}"
    summary = tracks_log.tracks_to_log(
        batch, out, container=container, msgtype=msgtype, observed=spans
    )
    marks = observed_marks.observed_stamps(spans)
    assert len(marks) == 3600 // 30 + 1 + 3599 // 30 + 1 + 1
    assert summary.detection_messages == 3
    assert summary.observed_messages == len(marks)
    assert summary.observed_spans == 2
    assert summary.observed_ns == 3600 * S + 3599 * S
    assert (summary.start_ns, summary.end_ns) == (spans[0][0], spans[1][1] - 1)
    from aion_cli.formats.log_zone import declared_spans

    assert declared_spans([out]) == {str(out): tuple(spans)}  # what aion build reads
    times, frames, windows = _log_messages(out)
    assert len(times) == 3 + len(marks)
    assert times == sorted(times)  # merged in time order
    assert sorted(set(times)) == sorted({*marks.tolist(), *batch.t_ns.tolist()})
    # every 600-s window either span touches holds a message
    for start, end in spans:
        touched = np.arange(start // (600 * S), (end - 1) // (600 * S) + 1)
        assert np.isin(touched, windows).all()
    # the detections are intact; the empty messages carry none
    assert len(frames) == len(batch)
    order = np.argsort(frames.t_ns, kind="stable")
    np.testing.assert_array_equal(frames.t_ns[order], batch.t_ns)
    np.testing.assert_allclose(frames.xyz[order], batch.xyz)
    if msgtype == tracks_log.SPENCER_TRACKED:
        np.testing.assert_array_equal(frames.track_id[order], batch.track_id)


def test_tracks_to_log_observed_without_detections_and_bad_spans(tmp_path: Path) -> None:
    summary = tracks_log.tracks_to_log(
        DetectionBatch.empty(), tmp_path / "e.mcap", observed=[(0, 60 * S)]
    )
    assert (summary.detections, summary.detection_messages, summary.observed_messages) == (0, 0, 3)
    times, frames, _ = _log_messages(tmp_path / "e.mcap")
    assert times == [0, 30 * S, 60 * S - 1]
    assert len(frames) == 0
    one = DetectionBatch.from_arrays([S], [[0, 0, 0]], track_id=[1])
    with pytest.raises(InputError, match="ends before it starts"):
        tracks_log.tracks_to_log(one, tmp_path / "b.mcap", observed=[(10 * S, 5 * S)])
    # without spans: only the detection messages, as before
    summary = tracks_log.tracks_to_log(one, tmp_path / "d.mcap")
    assert (summary.observed_messages, summary.observed_spans) == (0, 0)
    assert _log_messages(tmp_path / "d.mcap")[0] == [S]


def test_a_zero_speed_with_a_zero_angle_is_no_heading(tmp_path: Path) -> None:
    """THÖR writes speed 0.0 and angle 0.0 for a person standing: no direction, not a walk due
    east; a zero speed with an angle (ATC's tracker gives one) keeps it."""
    path = tmp_path / "t.csv"
    path.write_text("0.0,1,0.0,0.0,0.0,0.0\n0.1,1,0.0,0.0,0.0,0.5\n0.2,1,0.1,0.0,1.0,0.0\n")
    batch = ft.read_tracks(path, "thor", start_ns=1_600_000_000 * S)
    assert np.isnan(batch.heading[0])
    np.testing.assert_allclose(batch.heading[1:], [0.5, 0.0])
