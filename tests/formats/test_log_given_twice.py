"""One recording given twice under different names is read once.

A rosbag2 bag can be named by its folder or by a storage file beside its metadata.yaml; the
storage file opens the whole bag. Given both (``aion build bag bag/bag.mcap``), or two storage
files of one bag (``wbag_0.db3 wbag_1.db3``), every message was read twice and every person
counted twice; the same path twice was already used once (``aion_cli.provenance``).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.logs import open_logs
from tests.robustness.conftest import build_json, walk, write_log
from tests.shared_data import shared

WBAG = shared("logs", "rosbag2_tests", "rosbag2_py_sqlite3_wbag")


@pytest.mark.parametrize("container", ["rosbag2-mcap", "rosbag2-sqlite3"])
def test_a_bag_and_its_storage_file_are_read_once(tmp_path: Path, container: str) -> None:
    bag = write_log(tmp_path / "bag", walk(30), container)
    (storage,) = [p for p in bag.iterdir() if p.suffix in (".mcap", ".db3")]
    with open_logs([bag]) as alone:
        expected = alone.total()
    for paths in ([bag, storage], [storage, bag], [storage, storage]):
        with open_logs(paths) as logs:
            assert logs.total() == expected, paths
            assert len(logs.files) == 1
            assert any("is read already" in w and "used once" in w for w in logs.warnings)
    one = build_json(bag, "-o", tmp_path / "one.aion", "--map-frame", "map")
    both = build_json(bag, storage, "-o", tmp_path / "both.aion", "--map-frame", "map")
    assert both["detections"]["read"] == one["detections"]["read"] > 0
    assert not any("count twice" in w for w in both["warnings"])
    said = {  # the mcap file is read alone, so it is part of the bag; the db3 opens the bag
        "rosbag2-mcap": f"{storage} is part of {bag}, also given: it is used once",
        "rosbag2-sqlite3": f"{storage} opens the same rosbag2 bag as {bag}",
    }[container]
    assert any(said in n for n in both["notes"]), both["notes"]


@pytest.mark.skipif(not WBAG.is_dir(), reason="needs ../shared/data (rosbag2 test bags)")
def test_storage_files_of_one_bag_are_the_bag_once_and_said() -> None:
    """rosbag2's own test bag of five sqlite3 files (6,074 messages): two of its files are
    the bag once, and a file alone says it was read as the whole bag."""
    with open_logs([WBAG]) as folder:
        assert folder.total() == 6074
    with open_logs([WBAG / "wbag_0.db3", WBAG / "wbag_1.db3"]) as two:
        assert two.total() == 6074
        assert len(two.files) == 1
    with open_logs([WBAG / "wbag_3.db3"]) as one:
        assert one.total() == 6074
        assert any(
            "wbag_3.db3 is read with its whole rosbag2 bag" in w and "(5 storage files)" in w
            for w in one.warnings
        )
    for path in (WBAG, WBAG / "metadata.yaml"):  # the bag given: nothing to say (its
        # metadata.yaml was told to give the folder, or to copy the file to read it alone)
        with open_logs([path]) as bag:
            assert bag.total() == 6074
            assert not any("is read with its whole" in w for w in bag.warnings)
