"""``aion info`` and ``aion build`` over every file of the MCAP conformance suite
(../shared/data/logs/mcap_conformance: 342 files, each beside a ``.json`` listing the records a
correct reader must produce; tests/data keeps 8 of them when the shared data is absent).

``tests/formats/test_mcap_conformance.py`` checks the reader one level below the CLI; here the
two commands a user runs are checked against the suite's JSON: what ``info`` says of each file
(message count, first and last log time, size, compression, every channel with its schema
name, message encoding and message count, skipped as not ROS and said so), and that ``build``
refuses each with one error line and exit code 2, writing nothing: a file without messages as
such, the others because their channels (message encoding ``a``, schema encoding ``c``) hold no
ROS people detections.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from tests.cli.conftest import run, run_json
from tests.robustness.conftest import assert_one_error
from tests.shared_data import real_path

DATA = real_path("logs", "mcap_conformance")  # the whole suite, else tests/data's 8 files
NO_DATA = "the MCAP conformance suite (../shared/data/logs/mcap_conformance) is not available"


def _cases() -> list[str]:
    if not DATA.is_dir():
        return []
    return sorted(str(p.relative_to(DATA)) for p in DATA.glob("*/*.mcap"))


def _listed(path: Path) -> dict[str, Any]:
    """What the suite's JSON lists: message log times, messages per channel topic, each
    topic's schema name and message encoding, and the chunk indexes' compressions."""
    records = json.loads(path.with_suffix(".json").read_text())["records"]
    fields = [(r["type"], dict(r["fields"])) for r in records]
    schemas = {f["id"]: f["name"] for kind, f in fields if kind == "Schema"}
    channels = {f["id"]: f for kind, f in fields if kind == "Channel"}
    messages = [f for kind, f in fields if kind == "Message"]
    counts = Counter(channels[m["channel_id"]]["topic"] for m in messages)
    return {
        "times": [int(m["log_time"]) for m in messages],
        "topics": {
            c["topic"]: (schemas[c["schema_id"]], c["message_encoding"], counts[c["topic"]])
            for c in channels.values()
        },
        # the suite writes its chunks uncompressed: every ChunkIndex says "" (none); a file
        # without chunk indexes holds uncompressed chunks or none
        "compression": sorted(
            {f["compression"] or "none" for kind, f in fields if kind == "ChunkIndex"}
            or {"none"}
        ),
    }


@pytest.mark.skipif(not DATA.is_dir(), reason=NO_DATA)
@pytest.mark.parametrize("name", _cases() or ["none"])
def test_info_says_what_the_suite_lists(name: str) -> None:
    path = DATA / name
    listed = _listed(path)
    times = listed["times"]
    info = run_json("info", path, "--format", "json")
    (entry,) = info["files"]
    assert entry["messages"] == len(times)
    assert entry["size_bytes"] == info["size_bytes"] == path.stat().st_size
    assert info["compression"] == entry["compression"] == listed["compression"]
    first, last = (min(times), max(times)) if times else (None, None)
    assert (entry["start_ns"], entry["end_ns"]) == (first, last)
    assert (info["start_ns"], info["end_ns"]) == (first, last)
    shown = {t["topic"]: (t["type"], t["encoding"], t["count"]) for t in info["topics"]}
    assert shown == listed["topics"]
    # none of it is ROS: no message is readable, every topic is skipped and says why
    assert info["messages"] == 0
    assert info["roles"]["unsupported"] == sorted(listed["topics"])
    for topic in info["topics"]:
        assert (topic["role"], topic["readable"], topic["used"]) == ("unsupported", False, False)
        assert topic["why"] == "message encoding 'a' with schema encoding 'c' is not ROS"
    if not times:
        assert info["warnings"] == [f"{path}: no messages"]
    else:
        assert info["warnings"] == [
            f"{path.name}: topic {topic} skipped ({n:,} message{'' if n == 1 else 's'}): "
            "message encoding 'a' with schema encoding 'c' is not ROS"
            for topic, (_, _, n) in sorted(listed["topics"].items())
        ]


@pytest.mark.skipif(not DATA.is_dir(), reason=NO_DATA)
@pytest.mark.parametrize("name", _cases() or ["none"])
def test_build_refuses_each_file_with_one_line(name: str, tmp_path: Path) -> None:
    path = DATA / name
    out = tmp_path / "map.aion"
    result = run("build", path, "-o", out)
    assert result.exit_code == 2, result.stderr
    if _listed(path)["times"]:
        assert_one_error(
            result.stderr, "the log has no people-detection topic of a supported type"
        )
        assert "it has no ROS topic aion can read" in result.stderr
    else:
        assert_one_error(result.stderr, f"{path}: no messages")
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []
