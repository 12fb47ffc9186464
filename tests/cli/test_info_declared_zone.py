"""``aion info LOG`` names the time zone a log declares (``aion simulate --tz``): a ROS 1 bag
showed it only as its ``/aion/timezone`` topic, and an MCAP file or a rosbag2 folder (which
keep it in their metadata) not at all, though ``aion build`` follows it without ``--tz``."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import run, run_json


@pytest.mark.parametrize("container", ["mcap", "rosbag2"])
def test_info_names_the_zone_simulate_wrote(tmp_path: Path, container: str) -> None:
    log = tmp_path / ("tokyo.mcap" if container == "mcap" else "tokyo")
    made = run("simulate", "-o", log, "--days", "0.001", "--agents", "1", "--tz", "Asia/Tokyo",
               "--format", container, "-q")  # fmt: skip
    assert made.exit_code == 0, made.stderr
    doc = run_json("info", log, "--format", "json")
    assert doc["declared_zones"] == {str(log): "Asia/Tokyo"}
    table = run("info", log)
    assert table.exit_code == 0, table.stderr
    assert f"note: {log.name} declares the time zone Asia/Tokyo" in table.stderr
