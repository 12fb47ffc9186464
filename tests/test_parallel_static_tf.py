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


def _static_log(path: Path) -> None:
    """Only ``/tf_static`` base_link -> laser (the laser sits on the robot's origin), recorded
    a day before the people."""
    with LogWriter(path) as writer:
        stamp = {"sec": (T0 - DAY_NS) // 10**9, "nanosec": 0}
        writer.write(
            "/tf_static",
            "tf2_msgs/msg/TFMessage",
            {
                "transforms": [
                    {
                        "header": {"stamp": stamp, "frame_id": "base_link"},
                        "child_frame_id": "laser",
                        "transform": {"translation": {}, "rotation": {"w": 1.0}},
                    }
                ]
            },
            T0 - DAY_NS,
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
