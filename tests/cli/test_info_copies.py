"""``aion info LOG COPY`` of a log and a byte-identical copy of it counted every message twice
(``messages`` and each topic's ``count`` doubled, no word), while ``aion build`` of the same
two reads the copy once with a note: info's "what aion will use" said otherwise. Counted
against rosbags' own reading of the real rosbag.js example bag."""

from __future__ import annotations

import shutil
from collections import Counter
from pathlib import Path

from tests.cli.conftest import run, run_json
from tests.shared_data import real


def test_a_byte_identical_copy_is_read_once_with_a_warning(tmp_path: Path) -> None:
    from rosbags.rosbag1 import Reader

    log = real("logs", "rosbagjs_fixtures", "example-bz2.bag")
    with Reader(log) as reader:
        counts = Counter(conn.topic for conn, _, _ in reader.messages())
    copy = shutil.copyfile(log, tmp_path / "copy.bag")
    doc = run_json("info", log, copy, "--format", "json")
    assert doc["messages"] == sum(counts.values())
    assert {t["topic"]: t["count"] for t in doc["topics"]} == dict(counts)
    assert [Path(f["path"]).name for f in doc["files"]] == [log.name]
    assert f"{copy} is the same log as {log} (same sha256): it is used once" in doc["warnings"]
    table = run("info", log, copy)
    assert table.exit_code == 0, table.stderr
    assert f"messages: {sum(counts.values()):,}" in table.stdout.splitlines()[0]
    assert "copy.bag is the same log as" in " ".join(table.stderr.split())
