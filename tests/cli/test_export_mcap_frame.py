"""``aion export --format mcap`` of a map built in another frame than ``map``: a real laser
leg-tracker bag has no TF, and is built with ``--map-frame right_laser`` (the frame its
PoseArrays are in), so the map's positions are in ``right_laser``. The scene said they were
in ``map`` (every entity, marker and the file's ``frame`` metadata, ``/tf_static`` declaring
``world -> map``), so opened beside the bag, or any log whose TF places the laser (or
``odom`` for ``--map-frame odom``), it was drawn in the wrong place. The scene now names the
map's own frame."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoders
from mcap_ros2.decoder import DecoderFactory as Ros2Decoders

from tests.cli.conftest import run, run_json
from tests.shared_data import real

FRAME = "right_laser"


def test_the_scene_of_a_map_built_in_a_laser_frame_is_in_that_frame(tmp_path: Path) -> None:
    bag = real("logs", "leg_tracker", "positive_2_extracted.bag")
    out = tmp_path / "legs.aion"
    assert run("build", bag, "--map-frame", FRAME, "-o", out, "-q").exit_code == 0
    assert run_json("info", out, "--format", "json")["map_frame"] == FRAME
    scene = tmp_path / "legs.mcap"
    done = run("export", out, "--historical", "--format", "mcap", "-o", scene, "-q")
    assert done.exit_code == 0, done.stderr
    frames: dict[str, set[str]] = {}
    with scene.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[ProtobufDecoders(), Ros2Decoders()])
        (meta,) = [m.metadata for m in reader.iter_metadata() if m.name == "aion"]
        for _schema, channel, _message, msg in reader.iter_decoded_messages():
            if channel.topic == "/aion/scene":
                frames["entities"] = {e.frame_id for e in msg.entities}
            elif channel.topic == "/aion/markers":
                frames["markers"] = {m.header.frame_id for m in msg.markers}
            elif channel.topic == "/tf_static":
                (tf,) = msg.transforms
                frames["tf_static"] = {f"{tf.header.frame_id} -> {tf.child_frame_id}"}
    assert meta["frame"] == FRAME
    assert frames == {
        "entities": {FRAME},
        "markers": {FRAME},
        "tf_static": {f"world -> {FRAME}"},
    }


def test_info_and_the_report_name_the_map_s_frame(tmp_path: Path) -> None:
    """Every position ``predict`` and ``export`` give of such a map is in ``right_laser``,
    but neither ``aion info``'s table nor the report said which frame (only ``info
    --format json`` had ``map_frame``). Both name it now."""
    bag = real("logs", "leg_tracker", "positive_2_extracted.bag")
    out = tmp_path / "legs.aion"
    assert run("build", bag, "--map-frame", FRAME, "-o", out, "-q").exit_code == 0
    shown = run("info", out)
    assert shown.exit_code == 0, shown.stderr
    rows = [line.split("│")[1:3] for line in shown.stdout.splitlines() if "│" in line]
    assert ["map frame", FRAME] in [[cell.strip() for cell in row] for row in rows]
    page = tmp_path / "report"
    done = run("report", out, "-o", page, "-q")
    assert done.exit_code == 0, done.stderr
    assert f"<td>map frame</td><td>{FRAME}</td>" in (page / "index.html").read_text()
