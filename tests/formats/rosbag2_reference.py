"""rosbag2 bags read without aion's readers, as the expected answers of the container tests:
their own ``metadata.yaml`` and their storage files read with Python's ``sqlite3`` and the
``mcap`` library's reader."""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Any


def bag_metadata(folder: Path) -> dict[str, Any]:
    """The ``rosbag2_bagfile_information`` of the bag's ``metadata.yaml``."""
    from ruamel.yaml import YAML

    info: dict[str, Any] = YAML(typ="safe").load((folder / "metadata.yaml").read_text())
    return info["rosbag2_bagfile_information"]


def read_only(path: Path) -> sqlite3.Connection:
    """A connection that cannot change the file or anything beside it: ``mode=ro`` alone
    still creates ``-wal`` / ``-shm`` files next to a database it reads (a third party's
    bag under ``../shared/data`` must stay as it is); ``immutable=1`` takes no locks and
    keeps no journal."""
    return sqlite3.connect(f"file:{path}?mode=ro&immutable=1", uri=True)


def sqlite_messages(*files: Path) -> list[tuple[str, int, bytes]]:
    """``(topic, timestamp, data)`` of every message of rosbag2 sqlite3 files."""
    out: list[tuple[str, int, bytes]] = []
    for f in files:
        with read_only(f) as db:
            out += db.execute(
                "SELECT topics.name, timestamp, data FROM messages "
                "JOIN topics ON messages.topic_id = topics.id"
            ).fetchall()
    return sorted(out, key=lambda m: m[1])


def mcap_messages(*files: Path) -> list[tuple[str, int, bytes]]:
    """The same of mcap files, read with the mcap library's own reader."""
    from mcap.reader import make_reader

    out: list[tuple[str, int, bytes]] = []
    for f in files:
        with f.open("rb") as stream:
            reader = make_reader(stream)
            out += [(c.topic, m.log_time, m.data) for _, c, m in reader.iter_messages()]
    return sorted(out, key=lambda m: m[1])
