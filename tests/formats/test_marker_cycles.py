"""Lone ``visualization_msgs/Marker`` topics read a tracker's scan at a time: the Markers of
consecutive messages with one stamp and frame are one cycle, read as one MarkerArray.
leg_tracker's ``joint_leg_tracker.py`` publishes five Markers per person per scan (body, head,
label, arrow, ellipse; :mod:`tests.formats.joint_leg_tracker`), so read message by message
each person counted four times (the label is no person) with the ids of a count as track
ids; read by cycle each person counts once, without track id."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from aion_cli.formats.detections import adapter_for, hash_id
from aion_cli.formats.raw import RawMessage
from tests.formats.joint_leg_tracker import S, Scan, lone_markers, walking_scans
from tests.formats.ros_messages import raw

MARKER = "visualization_msgs/msg/Marker"
ROS = pytest.mark.parametrize("ros", [1, 2])
T0 = 1_700_000_000 * S


def _raws(markers: list[dict[str, Any]], ros: int) -> list[RawMessage]:
    return [raw(MARKER, m, ros, log_time_ns=T0 + 1000 * i) for i, m in enumerate(markers)]


def _expected(scans: list[Scan]) -> tuple[np.ndarray, np.ndarray]:
    """Independently: one row per person per scan at its body (x, y, 0.8), at the scan's
    stamp, in publishing order."""
    xyz = [(x, y, 0.8) for s in scans for x, y, _, _ in s.people]
    t = [s.stamp_ns for s in scans for _ in s.people]
    return np.array(xyz, np.float64), np.array(t, np.int64)


@ROS
def test_each_person_counts_once_per_scan(ros: int) -> None:
    scans = walking_scans(12, T0)
    messages = _raws(lone_markers(scans), ros)
    adapter = adapter_for(MARKER)
    assert adapter is not None
    d = adapter.decode(messages)
    xyz, t = _expected(scans)
    assert len(d) == len(xyz) == 18  # A in 12 scans, B in 6
    np.testing.assert_array_equal(d.xyz, xyz)
    np.testing.assert_array_equal(d.t_ns, t)
    np.testing.assert_array_equal(d.track_id, np.full(18, -1))  # ids count markers
    # per person: head, arrow, ellipse at the body's place, a label; the object and the
    # DELETEs of B's five ids in the odd scans and of the object's id after it
    deletes = 5 * 6 + 4
    assert d.filtered == {"marker_same_place": 3 * 18, "marker_text": 18,
                          "marker_delete": deletes, "marker_not_person": 4}  # fmt: skip
    assert len(messages) == len(d) + sum(d.filtered.values())


@ROS
def test_a_scan_cut_between_decode_calls_reads_as_one(ros: int) -> None:
    """The build decodes a topic in chunks; a scan cut between two calls of one adapter
    counts as if it were whole (its first part's places and ids go on into the next call),
    wherever the cut falls."""
    scans = walking_scans(4, T0)
    messages = _raws(lone_markers(scans), ros)
    whole = adapter_for(MARKER).decode(messages)  # type: ignore[union-attr]
    for cut in range(1, len(messages)):
        adapter = adapter_for(MARKER)
        assert adapter is not None
        a, b = adapter.decode(messages[:cut]), adapter.decode(messages[cut:])
        np.testing.assert_array_equal(np.r_[a.xyz, b.xyz], whole.xyz, err_msg=str(cut))
        np.testing.assert_array_equal(np.r_[a.track_id, b.track_id], whole.track_id)


@ROS
def test_a_damaged_message_inside_a_scan(ros: int) -> None:
    """A message that does not decode is counted and skipped; what the failed call had
    gathered is not read twice when its messages are decoded again one by one."""
    scans = walking_scans(2, T0)
    messages = _raws(lone_markers(scans), ros)
    bad = messages[3]  # A's label in scan 0
    messages[3] = RawMessage(bad.topic, bad.msgtype, bad.log_time_ns, bad.data[:9], bad.encoding)
    d = adapter_for(MARKER).decode(messages, on_error="skip")  # type: ignore[union-attr]
    xyz, _ = _expected(scans)
    np.testing.assert_array_equal(d.xyz, xyz)
    assert d.filtered["undecodable"] == 1
    assert d.filtered["marker_text"] == len(xyz) - 1


@ROS
def test_cycles_are_judged_as_arrays(ros: int) -> None:
    """A cycle is judged as a MarkerArray: ids 0..k-1 of a namespace count its markers (a
    cycle of one marker with id 0 too), ids that skip a number are track ids; a Marker with
    no stamp is read alone, its id a track id, 0 too (one marker says nothing of counting);
    the same stamp in two frames is two cycles."""

    def marker(sec: int, ns: str, mid: int, x: float, frame: str = "map") -> dict[str, Any]:
        return {"header": {"stamp": {"sec": sec}, "frame_id": frame}, "ns": ns, "id": mid,
                "type": 2, "pose": {"position": {"x": x}}}  # fmt: skip

    markers = [
        marker(5, "people", 0, 1.0), marker(6, "people", 0, 1.5),  # one marker per cycle
        marker(0, "people", 0, 2.0), marker(0, "people", 1, 2.5),  # unstamped: alone
        marker(7, "people", 3, 3.0), marker(7, "people", 8, 3.5),  # track ids 3 and 8
        marker(8, "legs", 0, 4.0), marker(8, "legs", 2, 4.5, "odom"),  # two frames
    ]  # fmt: skip
    d = adapter_for(MARKER).decode(_raws(markers, ros))  # type: ignore[union-attr]
    np.testing.assert_array_equal(d.xyz[:, 0], [1, 1.5, 2, 2.5, 3, 3.5, 4, 4.5])
    ids = [-1, -1] + [hash_id(f"{ns}/{i}") for ns, i in [
        ("people", 0), ("people", 1), ("people", 3), ("people", 8)]] + [-1, hash_id("legs/2")]
    np.testing.assert_array_equal(d.track_id, ids)
    np.testing.assert_array_equal(d.t_ns[:2], [5 * S, 6 * S])


@ROS
def test_the_id_rule_is_learnt_from_whole_scans(ros: int) -> None:
    """A build learns a namespace's id rule from the topic's first messages: the scans of
    lone Markers in them, but the last, which the sample may cut (here in a scan whose
    Markers came in reverse order: its first three ids, 9, 8 and 7, look like track ids).
    ``objects_tracked`` is no people and is not judged."""
    from aion_cli.formats.detections.markers import learn_ids

    scans = walking_scans(3, T0)
    markers = lone_markers(scans)
    last = [m for m in markers if m["header"]["stamp"]["nanosec"] == scans[2].stamp_ns % S]
    sample = _raws(markers[: len(markers) - len(last)] + last[::-1][:3], ros)
    adapter = adapter_for(MARKER)
    assert adapter is not None
    learn_ids(adapter, sample, sample[0].encoding)
    extract: Any = adapter.extract
    assert extract.verdicts == {"People_tracked": "counts"}
    assert extract.describe() == (
        "lone Markers read a scan at a time (the messages of one stamp and frame as one "
        "MarkerArray: one detection per person per scan); in its first 200 messages, the ids "
        "of 'People_tracked' count the markers (no track ids: linked); markers of "
        "'objects_tracked' are no people (leg_tracker's)"
    )


def test_a_scan_is_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    """Lone Markers that all share one stamp are not kept without end: past ``MAX_SCAN`` a
    scan starts afresh (here 4: the fifth marker at a place taken counts again)."""
    from aion_cli.formats.detections import markers

    monkeypatch.setattr(markers, "MAX_SCAN", 4)
    one_place = [{"header": {"stamp": {"sec": 3}, "frame_id": "map"}, "ns": "p", "id": i,
                  "type": 2, "pose": {"position": {"x": 1.0}}} for i in range(6)]  # fmt: skip
    d = adapter_for(MARKER).decode(_raws(one_place, 2))  # type: ignore[union-attr]
    assert len(d) == 2
    assert d.filtered == {"marker_same_place": 4}
