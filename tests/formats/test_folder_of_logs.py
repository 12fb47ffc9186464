"""A folder of several logs (the scenes ``aion simulate --scenes`` writes) is not a rosbag2 bag
without metadata.yaml: refused, the logs named; a bag's split storage files still are one."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.logs import open_logs
from tests.cli.conftest import assert_one_line_error, run
from tests.formats.log_builders import _write


@pytest.mark.parametrize("first", [0, 10], ids=["scene_00", "scene_10"])
def test_a_folder_of_separate_mcap_logs_is_refused(tmp_path: Path, first: int) -> None:
    """Two logs of the same hours: read as the splits of one bag, their people were
    interleaved into one recording, with only a warning."""
    folder = tmp_path / "sc"
    folder.mkdir()
    names = [f"scene_{k:02d}.mcap" for k in (first, first + 1)]
    for name in names:
        _write(folder / name, "mcap", n=4)
        (folder / f"{name}.truth.json").write_text("{}")
    result = run("build", folder, "-o", tmp_path / "sc.aion")
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, f"sc holds 2 logs ({names[0]}, {names[1]})")
    assert f"hint: give the logs themselves: aion build {folder}/*.mcap" in result.stderr
    assert not (tmp_path / "sc.aion").exists()
    with open_logs(sorted(folder.glob("*.mcap"))) as logs:  # given one by one: both read
        assert len(logs.files) == 2
        assert len(list(logs.messages(["/people"]))) == 8


@pytest.mark.parametrize(
    "names", [["run_0.mcap", "run_1.mcap", "run_2.mcap"], ["talker.mcap"]], ids=["splits", "one"]
)
def test_a_bag_folder_without_metadata_is_still_read(tmp_path: Path, names: list[str]) -> None:
    """rosbag2's split storage files (NAME_0.mcap, NAME_1.mcap, ...; the real ones:
    test_rosbag2_reindex.py::test_mcap_storage_files_without_metadata), or one storage file:
    indexed in memory as one bag, as before."""
    folder = tmp_path / "bag"
    folder.mkdir()
    for k, name in enumerate(names):
        _write(folder / name, "mcap", offset=1000 * k, n=4)
    with open_logs([folder]) as logs:
        assert len(list(logs.messages(["/people"]))) == 4 * len(names)
        assert "no metadata.yaml; indexed in memory" in logs.warnings[-1]
