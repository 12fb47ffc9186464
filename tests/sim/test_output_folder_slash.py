"""``aion simulate -o runs/`` of one scene in a log file: ``Path`` dropped the '/', and the
log was written as ``runs.mcap`` beside the folder the user named (exit 0). It is refused now,
as every other command refuses a file output named as a folder; a rosbag2 folder and a folder
of several scenes still take the '/'."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import assert_one_line_error, run


def test_one_scene_named_as_a_folder_is_refused(tmp_path: Path) -> None:
    result = run("simulate", "-o", f"{tmp_path / 'runs'}/", "--days", "0.001")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "ends in '/', which names a folder")
    assert not any(tmp_path.iterdir())  # before: runs.mcap and its truth files


def test_folders_still_take_a_slash(tmp_path: Path) -> None:
    bag = run("simulate", "-o", f"{tmp_path / 'bag2'}/", "--days", "0.001",
              "--format", "rosbag2", "-q")
    assert bag.exit_code == 0, bag.stderr
    assert (tmp_path / "bag2" / "metadata.yaml").is_file()
    many = run("simulate", "-o", f"{tmp_path / 'scenes'}/", "--days", "0.001", "--scenes", "2",
               "-q")
    assert many.exit_code == 0, many.stderr
    assert (tmp_path / "scenes" / "scene_01.mcap").is_file()
