"""``--force`` (``aion convert``, ``aion simulate``) replaces only logs aion wrote. An MCAP file
names its writer in its header; a ROS 1 bag and a rosbag2 folder name none, and ``--force``
took any bag and any folder of ``metadata.yaml`` plus storage files for aion's: a robot's
recording (``rosbag record``, ``ros2 bag record``) named as ``-o`` by mistake was destroyed.
aion now marks its bags (every connection's caller id ``/aion``) and its rosbag2 folders
(``custom_data: {writer: aion}`` in metadata.yaml), and replaces only those."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

from tests.cli.conftest import run
from tests.shared_data import real


def _tracks(tmp_path: Path) -> Path:
    src = tmp_path / "t.csv"
    src.write_text("0.0,1,0.0,0.0,1.0,0.0\n1.0,1,1.0,0.0,1.0,0.0\n")
    return src


def _digest(path: Path) -> str:
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    return hashlib.sha256(b"".join(p.read_bytes() for p in files)).hexdigest()


def test_force_refuses_a_recorded_ros1_bag(tmp_path: Path) -> None:
    bag = tmp_path / "robot.bag"
    shutil.copyfile(real("logs", "leg_tracker", "positive_2_extracted.bag"), bag)
    before = _digest(bag)
    for args in (
        ("convert", _tracks(tmp_path), "--layout", "thor", "-o", bag, "--force"),
        ("simulate", "-o", bag, "--format", "bag", "--days", "0.001", "--force"),
    ):
        result = run(*args)
        assert result.exit_code == 2, result.stderr  # before: exit 0, the recording replaced
        assert "not a ROS 1 bag aion wrote" in result.stderr
        assert _digest(bag) == before


def test_force_refuses_a_recorded_rosbag2_folder(tmp_path: Path) -> None:
    folder = tmp_path / "talker"
    shutil.copytree(real("logs", "rosbag2_tests", "rosbag2_py_mcap_talker"), folder)
    before = _digest(folder)
    result = run(
        "convert", _tracks(tmp_path), "--layout", "thor", "-o", folder,
        "--container", "rosbag2-mcap", "--force",
    )
    assert result.exit_code == 2, result.stderr
    assert "not a rosbag2 folder aion wrote" in result.stderr
    assert _digest(folder) == before


def test_force_still_replaces_aions_own_bag_and_rosbag2(tmp_path: Path) -> None:
    src = _tracks(tmp_path)
    for out, extra in ((tmp_path / "own.bag", ()), (tmp_path / "own", ("--container", "rosbag2"))):
        first = run("convert", src, "--layout", "thor", "-o", out, *extra)
        assert first.exit_code == 0, first.stderr
        again = run("convert", src, "--layout", "thor", "-o", out, *extra, "--force")
        assert again.exit_code == 0, again.stderr
    assert "writer: aion" in (tmp_path / "own" / "metadata.yaml").read_text()
