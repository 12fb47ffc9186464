"""A parallel build applies the static transforms of all its logs to every shard, as one pass
over the logs does: ``/tf_static`` is often recorded once, in a log of its own or only in the
first of several recordings."""

from __future__ import annotations

from pathlib import Path

from aion_cli.engine.compare import differences
from aion_cli.formats.writers import LogWriter
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import T0, write_office_log

DAY_NS = 86_400 * 10**9


def _static_log(path: Path, at_ns: int = T0 - DAY_NS, x: float = 0.0) -> None:
    """Only ``/tf_static`` base_link -> laser (the laser ``x`` metres ahead of the robot's
    origin), recorded and stamped at ``at_ns`` (by default a day before the people)."""
    with LogWriter(path) as writer:
        stamp = {"sec": at_ns // 10**9, "nanosec": at_ns % 10**9}
        writer.write(
            "/tf_static",
            "tf2_msgs/msg/TFMessage",
            {
                "transforms": [
                    {
                        "header": {"stamp": stamp, "frame_id": "base_link"},
                        "child_frame_id": "laser",
                        "transform": {"translation": {"x": x}, "rotation": {"w": 1.0}},
                    }
                ]
            },
            at_ns,
        )


def test_a_static_transform_in_another_log_reaches_every_shard(tmp_path: Path) -> None:
    """People in 'laser', the robot on /tf, base_link -> laser only in a log of the day before:
    --workers 2 stopped with "unknown frame 'laser'" (the people's shard never read the other
    log's /tf_static), while the sequential build used all 300 detections. Both now give the
    map of the same people logged in the map frame."""
    static, people = tmp_path / "static.mcap", tmp_path / "laser.mcap"
    reference = tmp_path / "map.mcap"
    _static_log(static)
    write_office_log(people, frame="laser")
    write_office_log(reference, frame="map")
    maps = {}
    for name, logs, workers in (
        ("reference", (reference,), 1),
        ("sequential", (static, people), 1),
        ("parallel", (static, people), 2),
    ):
        maps[name] = tmp_path / f"{name}.aion"
        report = build_map(BuildOptions(logs=logs, output=maps[name], workers=workers))
        assert report.detections_used == 300, name
    states = {k: load_map(v, writable=True).state for k, v in maps.items()}
    assert differences(states["sequential"], states["parallel"]) == []
    assert differences(states["reference"], states["parallel"]) == []


def test_a_static_transform_that_changed_holds_from_its_stamp_on(tmp_path: Path) -> None:
    """The laser at the robot's origin on the people's day, then remounted 100 m ahead (or
    another robot's logs with the same frame names) a day later: the later /tf_static was
    applied to every log, so the first day's people were mapped 100 m away. Each static
    transform now holds from its stamp on; both builds give the map of the people logged in
    the map frame."""
    before, after = tmp_path / "before.mcap", tmp_path / "after.mcap"
    people, reference = tmp_path / "laser.mcap", tmp_path / "map.mcap"
    _static_log(before, T0 - 3600 * 10**9)
    _static_log(after, T0 + DAY_NS, x=100.0)
    write_office_log(people, frame="laser")
    write_office_log(reference, frame="map")
    maps = {}
    for name, logs, workers in (
        ("reference", (reference,), 1),
        ("sequential", (before, people, after), 1),
        ("parallel", (before, people, after), 2),
    ):
        maps[name] = tmp_path / f"{name}.aion"
        report = build_map(BuildOptions(logs=logs, output=maps[name], workers=workers))
        assert report.detections_used == 300, name
    states = {k: load_map(v, writable=True).state for k, v in maps.items()}
    assert differences(states["reference"], states["sequential"]) == []
    assert differences(states["reference"], states["parallel"]) == []
