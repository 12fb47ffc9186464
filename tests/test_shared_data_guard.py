"""The suite's guard on the shared data (tests/conftest.py) sees every kind of change."""

from __future__ import annotations

import os
from pathlib import Path

from tests.conftest import changed_paths, tree_snapshot


def test_the_guard_names_added_removed_and_changed_files(tmp_path: Path) -> None:
    (tmp_path / "bag").mkdir()
    (tmp_path / "bag" / "talker.db3").write_bytes(b"x" * 10)
    (tmp_path / "old.mcap").write_bytes(b"y")
    before = tree_snapshot(tmp_path)
    assert changed_paths(before, tree_snapshot(tmp_path)) == []
    (tmp_path / "bag" / "talker.db3-wal").write_bytes(b"")  # what mode=ro left behind
    (tmp_path / "old.mcap").unlink()
    target = tmp_path / "bag" / "talker.db3"
    target.write_bytes(b"z" * 10)  # same size, later time
    os.utime(target, ns=(1, before["bag/talker.db3"][1] + 10**9))
    assert changed_paths(before, tree_snapshot(tmp_path)) == [
        "bag",
        "bag/talker.db3",
        "bag/talker.db3-wal",
        "old.mcap",
    ]
    assert tree_snapshot(tmp_path / "absent") == {}
