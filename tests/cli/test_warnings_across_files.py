"""A warning said alike of many files prints once, naming how many and the first few.

``aion info`` on the MCAP conformance suite's 154 TenMessages files printed 154 lines of
``NAME.mcap: topic example skipped (10 messages): ... is not ROS``, one per file (the files
differ in name only, so :func:`warning_shape` keeps them apart, on purpose: two files' skipped
chunks are two problems). The text output now says it once ``in 154 files (a, b, c and 151
more)``; a warning of one file, or texts that differ beyond the file's name, print as before,
and the JSON keeps every warning.
"""

from __future__ import annotations

import json

import pytest

from aion_cli.cli.console import across_files, warn_each
from tests.cli.conftest import run
from tests.shared_data import FIXTURES

TEN = FIXTURES / "logs" / "mcap_conformance" / "TenMessages"
SKIPPED = (
    "topic example skipped (10 messages): message encoding 'a' with schema encoding 'c' is not ROS"
)


def test_one_warning_of_three_files_is_one_line_naming_them() -> None:
    messages = [
        "a.mcap: chunk at byte 33 skipped",
        "a.mcap: topic /x skipped",
        "b.mcap: topic /x skipped",
        "/tf: 3 undecodable",  # a topic, not a file
        "c.mcap: topic /x skipped",
        "b.mcap: chunk at byte 84 skipped",  # another text than a.mcap's: its own line
    ]
    assert across_files(messages) == [
        "a.mcap: chunk at byte 33 skipped",
        "topic /x skipped in 3 files (a.mcap, b.mcap, c.mcap)",
        "/tf: 3 undecodable",
        "b.mcap: chunk at byte 84 skipped",
    ]


def test_a_warning_of_one_file_is_left_as_it_is() -> None:
    messages = ["a.mcap: topic /x skipped", "a.mcap: topic /x skipped", "b.bag: topic /y skipped"]
    assert across_files(messages) == messages


def test_more_files_than_named_are_counted(capsys: pytest.CaptureFixture[str]) -> None:
    warn_each([f"log_{k}.mcap: topic /x skipped" for k in range(5)])
    assert capsys.readouterr().err.splitlines() == [
        "warning: topic /x skipped in 5 files (log_0.mcap, log_1.mcap, log_2.mcap and 2 more)"
    ]


def test_info_on_three_logs_says_their_skipped_topic_once() -> None:
    logs = sorted(TEN.glob("*.mcap"))[:3]
    assert len(logs) == 3
    described = json.loads(run("info", *logs, "--format", "json").stdout)
    assert len(described["warnings"]) == 3  # the JSON keeps one per file
    named = [w.removesuffix(f": {SKIPPED}") for w in described["warnings"]]
    assert sorted(named) == [log.name for log in logs]
    result = run("info", *logs)
    assert result.exit_code == 0, result.stderr
    warned = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert warned == [f"warning: {SKIPPED} in 3 files ({', '.join(named)})"]


def test_info_on_one_log_names_it_as_before() -> None:
    log = sorted(TEN.glob("*.mcap"))[0]
    result = run("info", log)
    assert result.exit_code == 0, result.stderr
    warned = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert warned == [f"warning: {log.name}: {SKIPPED}"]
