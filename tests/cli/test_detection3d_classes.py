"""A ROS 2 ``vision_msgs/Detection3DArray`` tracker whose people are not of class "person":
the build that keeps none says what the class filter keeps and how to read the topic with a
mapping, and the mapping it suggests reads every detection; a mapping's filter on
``results[0]`` drops a detection with no results as a short array, not the whole build."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import assert_one_line_error, run, run_json

S = 1_000_000_000
T0 = 1_767_600_000 * S
TOPIC = "/people_detections"
DET3D = "vision_msgs/msg/Detection3DArray"
MESSAGES = 30


def detections_log(path: Path, classes: tuple[str | None, ...]) -> Path:
    """One detection per class of ``classes`` in each message (None: no results at all),
    walking apart along y = 2 k; ids are their positions in ``classes``."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path, "mcap") as w:
        for k in range(MESSAGES):
            t = T0 + k * S // 2
            dets = []
            for n, cls in enumerate(classes):
                centre = {"position": {"x": 0.5 * k, "y": 2.0 * n}, "orientation": {"w": 1.0}}
                results = [] if cls is None else [{"hypothesis": {"class_id": cls, "score": 1.0}}]
                dets.append({"results": results, "bbox": {"center": centre}, "id": str(n)})
            header = {"stamp": {"sec": t // S, "nanosec": t % S}, "frame_id": "map"}
            w.write(TOPIC, DET3D, {"header": header, "detections": dets}, t)
    return path


def test_a_tracker_of_pedestrians_is_told_how_to_read_them(tmp_path: Path) -> None:
    log = detections_log(tmp_path / "peds.mcap", ("pedestrian", "pedestrian"))
    out = tmp_path / "m.aion"
    refused = run("build", log, "-o", out)
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, f"dropped: class {2 * MESSAGES}")
    hint = " ".join(refused.stderr.split())
    assert "vision_msgs detections of class 'person'" in hint, hint
    assert f"`aion info LOG --suggest-mapping {TOPIC}` writes one" in hint, hint
    assert not out.exists()
    suggested = run("info", log, "--suggest-mapping", TOPIC)
    assert suggested.exit_code == 0, suggested.stderr
    mapping = tmp_path / "peds.toml"
    mapping.write_text(suggested.stdout)
    report = run_json("build", log, "-o", out, "--detections-mapping", mapping, "--format",
                      "json")  # fmt: skip
    assert report["detections"] == {"read": 2 * MESSAGES, "used": 2 * MESSAGES, "dropped": {}}


def test_a_filter_on_the_first_result_drops_detections_without_results(tmp_path: Path) -> None:
    log = detections_log(tmp_path / "mixed.mcap", ("pedestrian", None, "car", "pedestrian"))
    mapping = tmp_path / "peds.toml"
    mapping.write_text(
        f'[[topic]]\ntopic = "{TOPIC}"\nmsgtype = "{DET3D}"\narray = "detections"\n'
        'position = "bbox.center.position"\nid = "id"\n'
        'filter = { field = "results[0].hypothesis.class_id", equals = ["pedestrian"] }\n'
    )
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--detections-mapping", mapping,
                      "--format", "json")  # fmt: skip
    assert report["detections"] == {
        "read": 4 * MESSAGES,
        "used": 2 * MESSAGES,
        "dropped": {"filter": MESSAGES, "short_array": MESSAGES},
    }
