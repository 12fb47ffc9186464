"""``aion info`` (and ``build``, ``predict``) on a scene ``aion export --format mcap`` wrote:
each says the file is an exported scene, not a log to map (``test_export_mcap.py`` checks the
scene itself)."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader

from tests.cli.conftest import Office, assert_one_line_error, run, run_json
from tests.shared_data import real


def test_info_on_an_exported_scene_says_what_it_is(office: Office, tmp_path: Path) -> None:
    """``aion info scene.mcap`` on a scene aion exported told the user to write a detections
    mapping for aion's own markers ('map another type: aion info LOG --suggest-mapping
    /aion/markers'), and ``aion build scene.mcap`` to name /aion/markers with
    --detections-topic; both say the file is an exported scene, and a recorded log keeps its
    pointer."""
    out = tmp_path / "scene.mcap"
    assert run("export", office.map, "--historical", "--format", "mcap", "-o", out).exit_code == 0
    said = " ".join(run("info", out).stderr.split())
    assert "(it is a scene aion exported, to open in Foxglove or RViz: one step, at " in said, said
    assert "--suggest-mapping" not in said, said
    # its header said "2 readable of 3 (the others: see the topics)", and the topics did not
    # say which: the one protobuf channel (Foxglove's SceneUpdate), which it now names
    with out.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    stats = summary.statistics
    assert stats is not None
    (scene,) = [c for c in summary.channels.values() if c.message_encoding == "protobuf"]
    n, total = stats.channel_message_counts[scene.id], stats.message_count
    header = " ".join(run("info", out).stdout.split())
    assert (
        f"messages: {total - n} readable of {total} (the rest: {n} on {scene.topic} (protobuf), "
        "which aion's ROS readers do not decode)" in header
    ), header
    log = " ".join(run("info", office.log).stderr.split())
    assert "scene aion exported" not in log
    built = run("build", out, "-o", tmp_path / "x.aion")  # hinted --detections-topic /aion/...
    assert built.exit_code == 2
    assert_one_line_error(built.stderr, "no people-detection topic")
    assert "hint: it is a scene aion exported" in built.stderr, built.stderr
    assert "--detections-topic" not in built.stderr
    asked = run("predict", out)  # said 'scene.mcap is a log: build a map from it first'
    assert asked.exit_code == 2
    assert "hint: scene.mcap is a scene aion exported from a map: give that map" in asked.stderr


def test_info_json_on_an_exported_scene_lists_no_topic_it_cannot_read(
    office: Office, tmp_path: Path
) -> None:
    """``aion info scene.mcap --format json`` listed aion's own ``/aion/markers`` under
    ``cannot_read`` and offered it as the ``mapping_example`` while the table said the file is
    an exported scene; a recorded log's generic markers stay under ``cannot_read``."""
    out = tmp_path / "scene.mcap"
    assert run("export", office.map, "--historical", "--format", "mcap", "-o", out).exit_code == 0
    report = run_json("info", out, "--format", "json")
    assert "/aion/markers" in {t["topic"] for t in report["topics"]}
    assert report["cannot_read"] == []
    assert report["mapping_example"] is None
    assert report["will_use"]["detections"] == []
    bag = real("logs", "leg_tracker", "positive_2_extracted.bag")  # a recorded log's markers
    recorded = run_json("info", bag, "--format", "json")
    markers = "/visualization_marker_array (visualization_msgs/msg/MarkerArray)"
    assert markers in recorded["cannot_read"]


def test_info_names_an_exported_scene_s_steps_on_the_table_s_clock(
    office: Office, tmp_path: Path
) -> None:
    """The note on a scene aion exported gave its steps as UTC ISO stamps
    (``2026-01-12T08:40:00.000000Z``) under a header on the clock of ``--tz`` (``17:40:00
    Asia/Tokyo``): two clocks in one table. Both give the step at 08:40 UTC on Tokyo's."""
    out = tmp_path / "scene.mcap"
    made = run("export", office.map, "--time", "2026-01-12 08:40", "--tz", "UTC",
               "--format", "mcap", "-o", out)  # fmt: skip
    assert made.exit_code == 0, made.stderr
    shown = run("info", out, "--tz", "Asia/Tokyo")
    assert shown.exit_code == 0, shown.stderr
    header, said = " ".join(shown.stdout.split()), " ".join(shown.stderr.split())
    assert "(2026-01-12 17:40:00 .. 2026-01-12 17:40:00 Asia/Tokyo)" in header, header
    assert "RViz: one step, at 2026-01-12 17:40:00)" in said, said
