"""The size ``aion info`` gives a rosbag2 folder is its storage files' (what ``ros2 bag info``
counts), whatever the storage: an sqlite3 bag's counted every file of the folder
(metadata.yaml, and anything left beside it), its mcap twin's only the .mcap files, so one
recording showed two sizes; and the table names an mcap-storage bag by its folder, as an
sqlite3 bag. Checked against the files that the bag's own metadata.yaml lists (and their sizes
on disk), on the real rosbag2 test bags."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from tests.cli.conftest import run, run_json
from tests.shared_data import real


def _storage_bytes(folder: Path) -> int:
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return sum((folder / name).stat().st_size for name in meta["relative_file_paths"])


@pytest.mark.parametrize(
    "name", ["rosbag2_py_sqlite3_talker", "rosbag2_py_mcap_talker", "ros2bag_empty_bag"]
)
def test_a_folder_s_size_is_its_storage_files(name: str, tmp_path: Path) -> None:
    folder = real("logs", "rosbag2_tests", name)
    expected = _storage_bytes(folder)
    assert expected < sum(f.stat().st_size for f in folder.iterdir())  # metadata.yaml is not
    doc = run_json("info", folder, "--format", "json")
    assert doc["size_bytes"] == expected
    assert sum(f["size_bytes"] for f in doc["files"]) == expected
    copy = shutil.copytree(folder, tmp_path / name)
    copy.chmod(0o755)  # the shared data is read-only
    (copy / "notes.txt").write_text("recorded by the night shift\n" * 100)  # not the bag's
    assert run_json("info", copy, "--format", "json")["size_bytes"] == expected


@pytest.mark.parametrize("name", ["rosbag2_py_mcap_talker", "rosbag2_py_mcap_wbag"])
def test_the_table_names_an_mcap_storage_bag_by_its_folder(name: str) -> None:
    """The table's first line named an mcap-storage bag by its storage files ("wbag_0.mcap,
    wbag_1.mcap, ...", five for one recording) where an sqlite3 bag is named by its folder."""
    folder = real("logs", "rosbag2_tests", name)
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    storage = meta["relative_file_paths"]
    assert storage
    assert all(s.endswith(".mcap") for s in storage)
    table = run("info", folder)
    assert table.exit_code == 0, table.stderr
    first = table.stdout.splitlines()[0]
    assert first.startswith(f"{name}  format: rosbag2-mcap  size: "), first
    assert not any(s in first for s in storage), first
    sqlite = run("info", real("logs", "rosbag2_tests", "rosbag2_py_sqlite3_talker"))
    assert sqlite.stdout.startswith("rosbag2_py_sqlite3_talker  format: rosbag2-sqlite3  size: ")


@pytest.mark.parametrize(
    ("name", "extra"),
    [("rosbag2_py_sqlite3_talker", "talker_1.db3"), ("rosbag2_py_mcap_talker", "talker_1.mcap")],
)
def test_a_storage_file_metadata_yaml_does_not_list_is_named(
    name: str, extra: str, tmp_path: Path
) -> None:
    """A storage file beside a bag's that its metadata.yaml does not list (a split written
    after the yaml, a file copied in) was left out without a word: info counted the listed
    files' messages only, as if the folder held nothing else."""
    folder = real("logs", "rosbag2_tests", name)
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    (listed,) = meta["relative_file_paths"]
    clean = run_json("info", folder, "--format", "json")
    assert not [w for w in clean["warnings"] if "not listed" in w]
    copy = shutil.copytree(folder, tmp_path / name)
    copy.chmod(0o755)  # the shared data is read-only
    shutil.copyfile(copy / listed, copy / extra)  # a second recording of the same messages
    doc = run_json("info", copy, "--format", "json")
    assert doc["messages"] == meta["message_count"]  # the listed file's, as before
    (warning,) = [w for w in doc["warnings"] if "not listed" in w]
    assert f"{extra} beside the bag's storage files is not listed in its metadata.yaml" in warning
    assert listed not in warning
