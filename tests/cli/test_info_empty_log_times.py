"""``aion info --format json`` of a log without messages gave it the times 0 (``start``
"1970-01-01T00:00:00.000000Z", ``duration_s`` 0.0) while its table said "duration: none (no
messages)": a script read a recording of 1970. The times are null now, for the log and for
each empty file beside others; those of a file with messages are its own. Checked on the real
empty bags of rosbag.js and rosbag2, and the first and last message times rosbags reads."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import run, run_json
from tests.shared_data import real


def test_an_empty_log_has_no_times(tmp_path: Path) -> None:
    from rosbags.rosbag1 import Reader

    for empty in (
        real("logs", "rosbagjs_fixtures", "no-messages.bag"),
        real("logs", "rosbag2_tests", "ros2bag_empty_bag"),
    ):
        doc = run_json("info", empty, "--format", "json")
        assert doc["messages"] == 0
        assert (doc["start_ns"], doc["end_ns"], doc["start"], doc["end"]) == (None,) * 4
        assert (doc["files"][0]["start_ns"], doc["files"][0]["end_ns"]) == (None, None)
        assert "duration: none (no messages)" in run("info", empty).stdout

    log = real("logs", "rosbagjs_fixtures", "example-bz2.bag")
    with Reader(log) as reader:
        times = [t for _, t, _ in reader.messages()]
    both = run_json("info", log, real("logs", "rosbagjs_fixtures", "no-messages.bag"),
                    "--format", "json")
    assert (both["start_ns"], both["end_ns"]) == (min(times), max(times))
    assert both["start"].startswith("2014-03-31T")
    files = {Path(f["path"]).name: (f["start_ns"], f["end_ns"]) for f in both["files"]}
    assert files == {"example-bz2.bag": (min(times), max(times)), "no-messages.bag": (None, None)}
