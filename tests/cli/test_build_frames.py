"""Frame names on the command line are spelt as the logs' frame ids are compared: ROS 1 tools
write ``/map`` where ROS 2 writes ``map``, and both name one frame."""

from __future__ import annotations

from pathlib import Path

from aion_cli.formats.mapfile import read_manifest
from tests.cli.conftest import run_json
from tests.cli.logdata import write_office_log


def test_a_leading_slash_on_map_frame_names_the_logs_frame(tmp_path: Path) -> None:
    """Detections in 'map' and no TF: ``--map-frame /map`` stopped the build with "detections
    are in frame 'map' but the log has no TF to '/map'" (and the map recorded '/map', so
    continuing it with 'map' warned of two frames). All 300 detections are used either way."""
    log = tmp_path / "office.mcap"
    write_office_log(log, tf=False, graph=False)
    first = tmp_path / "first.aion"
    report = run_json("build", log, "--map-frame", "/map", "-o", first, "--format", "json")
    assert report["detections"]["used"] == 300
    assert read_manifest(first)["map_frame"] == "map"
    later = tmp_path / "later.mcap"
    write_office_log(later, tf=False, graph=False, shift_s=3 * 86_400)
    report = run_json("build", later, "--map", first, "--map-frame", "map", "-o",
                      tmp_path / "both.aion", "--format", "json")
    assert report["detections"]["used"] == 300
    assert not [w for w in report["warnings"] if "holds positions in frame" in w]
