"""The RViz MarkerArray of the real leg_tracker bags: its markers are numbered 0, 1, ... in
every message (leg_tracker's ``extract_positive_training_clusters`` sets ``m.id = i``), so an
id is a place in the message, not a person. Read as track ids, id 0 jumped from one leg to
another between messages and gave 317 "track" headings of positive_1 that differenced two
people; read as numbers, the markers are linked into tracks like the PoseArray's poses they
were drawn from (same x, y: one SPHERE per pose, in frame ``laser_frame``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import map_cells, run, run_json
from tests.shared_data import real

MARKERS = "/visualization_marker_array"


def _cells(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A map's cells (centres, counts per direction bin, undirected), in centre order."""
    xy, counts, nodir = map_cells(path)
    order = np.lexsort(xy.T)
    return xy[order], counts[order], nodir[order]


@pytest.mark.parametrize("name", ["positive_1_extracted.bag", "positive_2_extracted.bag"])
def test_numbered_markers_make_the_map_of_the_poses_they_draw(name: str, tmp_path: Path) -> None:
    log = real("logs", "leg_tracker", name)
    poses = run_json("build", log, "-o", tmp_path / "poses.aion", "--map-frame", "right_laser",
                     "--workers", "1", "--format", "json")  # fmt: skip
    markers = run_json("build", log, "-o", tmp_path / "markers.aion", "--map-frame",
                       "laser_frame", "--detections-topic", MARKERS, "--workers", "1",
                       "--format", "json")  # fmt: skip
    assert markers["detection_topics"] == [MARKERS]
    assert markers["detections"]["used"] == poses["detections"]["used"]
    assert markers["headings"]["track"] == 0
    assert markers["headings"] == poses["headings"]
    for a, b in zip(_cells(tmp_path / "markers.aion"), _cells(tmp_path / "poses.aion"),
                    strict=True):  # fmt: skip
        np.testing.assert_array_equal(a, b)


def _marker_bag(path: Path, ids: tuple[int, int]) -> Path:
    """A MarkerArray on /people_markers: two SPHEREs per message with the ids ``ids``, one
    walking +x from (0, 0), one -x from (10, 5), 0.5 m per second, for 10 seconds."""
    from aion_cli.formats.writers import LogWriter

    t0 = 1_700_000_400 * 1_000_000_000
    with LogWriter(path, "bag") as w:
        for k in range(10):
            t = t0 + k * 1_000_000_000
            stamp = {"sec": t // 1_000_000_000, "nanosec": 0}
            markers = [
                {"header": {"stamp": stamp, "frame_id": "map"}, "ns": "people", "id": i,
                 "type": 2, "pose": {"position": {"x": x, "y": y},
                                     "orientation": {"w": 1.0}}}
                for i, x, y in ((ids[0], 0.5 * k, 0.0), (ids[1], 10.0 - 0.5 * k, 5.0))
            ]  # fmt: skip
            w.write("/people_markers", "visualization_msgs/msg/MarkerArray",
                    {"markers": markers}, t)  # fmt: skip
    return path


def test_suggest_mapping_offers_no_id_that_numbers_the_markers(tmp_path: Path) -> None:
    """--suggest-mapping read only the type and offered ``id = "id"  # track id`` for the
    leg_tracker markers, whose ids the build takes for numbers (0..k-1 in every message);
    it now looks at the first messages and says why it offers no id. Markers whose ids are
    no count (4 and 9 in every message) still get the id."""
    from aion_cli.formats.detections.mapping import load_mapping

    suggested = run("info", real("logs", "leg_tracker", "positive_1_extracted.bag"),
                    "--suggest-mapping", MARKERS)  # fmt: skip
    assert suggested.exit_code == 0, suggested.stderr
    assert not any(line.startswith("id =") for line in suggested.stdout.splitlines())
    assert "# id: none (id numbers each message's markers 0..k-1" in suggested.stdout
    mapping = tmp_path / "markers.toml"
    mapping.write_text(suggested.stdout)
    assert load_mapping(mapping)[0].topic == MARKERS  # still a loadable mapping
    for ids, offered in (((0, 1), False), ((4, 9), True)):
        log = _marker_bag(tmp_path / f"m{ids[0]}.bag", ids)
        text = run("info", log, "--suggest-mapping", "/people_markers").stdout
        assert ('id = "id"' in text) is offered, text


def test_lone_markers_of_joint_leg_tracker_count_each_person_once(tmp_path: Path) -> None:
    """``joint_leg_tracker.py`` publishes five lone Markers per person per scan on one topic
    (tests/formats/joint_leg_tracker.py). The build used every one of them but the labels
    (four detections per person per scan, each with a count for track id); it now uses one
    per person per scan, links them (the ids count markers) and says what it left out, with
    no warning of a loss: it warned "2,750 of its 3,200 detections (86 %) could not be used
    (dropped: )" -- the markers it leaves out by choice counted as lost, none listed."""
    from aion_cli.formats.writers import LogWriter
    from tests.formats.joint_leg_tracker import lone_markers, walking_scans

    scans = walking_scans(60, 1_700_000_400 * 1_000_000_000)
    log = tmp_path / "lone.bag"
    with LogWriter(log, "bag") as w:
        for i, m in enumerate(lone_markers(scans)):
            t = m["header"]["stamp"]["sec"] * 1_000_000_000 + m["header"]["stamp"]["nanosec"]
            w.write("/visualization_marker", "visualization_msgs/msg/Marker", m, t + 1000 * i)
    people = sum(len(s.people) for s in scans)  # 60 of A, 30 of B
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--detections-topic",
                      "/visualization_marker", "--workers", "1", "--format", "json")  # fmt: skip
    assert report["detections"]["used"] == people == 90
    assert report["detections"]["dropped"] == {
        "marker_same_place": 3 * people, "marker_text": people,
        "marker_delete": 5 * 30 + 20, "marker_not_person": 20,
    }  # fmt: skip
    assert report["headings"]["track"] == 0
    assert not any("could not be used" in w for w in report["warnings"])


def test_real_marker_arrays_give_one_detection_per_leg(tmp_path: Path) -> None:
    """Independently of aion: per message of positive_2's MarkerArray, the distinct x, y of
    its markers (rosbags reads them); the build uses exactly that many."""
    from rosbags.highlevel import AnyReader

    log = real("logs", "leg_tracker", "positive_2_extracted.bag")
    places = 0
    with AnyReader([log]) as reader:
        conns = [c for c in reader.connections if c.topic == MARKERS]
        for c, _, data in reader.messages(connections=conns):
            msg = reader.deserialize(data, c.msgtype)
            places += len({(m.pose.position.x, m.pose.position.y) for m in msg.markers})
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--map-frame", "laser_frame",
                      "--detections-topic", MARKERS, "--workers", "1",
                      "--format", "json")  # fmt: skip
    assert places > 83  # more than one leg in some messages
    assert report["detections"]["used"] == places


def _one_person(path: Path, marker_id: int) -> Path:
    """A MarkerArray on /people_markers holding one SPHERE of id ``marker_id`` per message:
    one person walking a circle of 5 m at 0.5 m/s, 10 messages a second for 60 s."""
    import math

    from aion_cli.formats.writers import LogWriter

    t0 = 1_700_000_400 * 1_000_000_000
    with LogWriter(path, "bag") as w:
        for k in range(600):
            t = t0 + k * 100_000_000
            a = k * 0.01
            marker = {"header": {"stamp": {"sec": t // 10**9, "nanosec": t % 10**9},
                                 "frame_id": "map"},
                      "ns": "people", "id": marker_id, "type": 2,
                      "pose": {"position": {"x": 5 * math.cos(a), "y": 5 * math.sin(a)},
                               "orientation": {"w": 1.0}}}  # fmt: skip
            w.write("/people_markers", "visualization_msgs/msg/MarkerArray",
                    {"markers": [marker]}, t)  # fmt: skip
    return path


def test_one_person_whose_track_id_is_0_builds_the_map_of_any_other_id(tmp_path: Path) -> None:
    """A MarkerArray of one marker with id 0 was read as a count of one (no track id): the
    person's rows were linked, and the map differed from the same walk with id 7 (600 linked
    headings against 598 track headings; 8 of the map's arrays differed). The topic's first
    messages show only id 0, one person's: now it is a track id and the two maps are equal
    (the manifest's inputs and created aside); info and build say how the ids are read, and
    --suggest-mapping offers the id."""
    import zipfile

    maps = {}
    for marker_id in (0, 7):
        log = _one_person(tmp_path / f"one{marker_id}.bag", marker_id)
        out = maps[marker_id] = tmp_path / f"one{marker_id}.aion"
        report = run_json("build", log, "-o", out, "--workers", "1", "--format", "json")
        assert report["headings"]["track"] == 598, report["headings"]
        assert report["headings"]["linked"] == 0
    a, b = zipfile.ZipFile(maps[0]), zipfile.ZipFile(maps[7])
    assert sorted(a.namelist()) == sorted(b.namelist())
    for name in a.namelist():
        if name != "manifest.json":
            assert a.read(name) == b.read(name), name
    log = tmp_path / "one0.bag"
    said = "the ids of 'people' are only 0, one person's track id"
    again = run_json("build", log, "-o", tmp_path / "again.aion", "--format", "json")
    assert f"/people_markers: in its first 200 messages, {said}" in again["notes"]
    (topic,) = run_json("info", log, "--format", "json")["topics"]
    assert topic["why"].endswith(said)
    assert 'id = "id"' in run("info", log, "--suggest-mapping", "/people_markers").stdout
