"""``aion info`` of a real log with no people in it (a turtlesim bag, a rosbag2 talker, a bag
with no messages, an MCAP of another encoding) said, after "`aion build` cannot learn flows
from this log", also "no scene graph: build with --graph FILE or --derive-graph": advice that
cannot work (the build refuses the log whatever graph it is given, and --derive-graph derives
places from the people it has not got). The note is kept for a log that has people and no
graph: there, --graph or --derive-graph is what the build needs."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import run
from tests.shared_data import real

NO_GRAPH = "no scene graph: build with --graph FILE or --derive-graph"


@pytest.mark.parametrize(
    "parts",
    [
        ("logs", "rosbagjs_fixtures", "example-bz2.bag"),  # turtlesim: Twist, Color, Pose
        ("logs", "rosbagjs_fixtures", "no-messages.bag"),
        ("logs", "rosbag2_tests", "rosbag2_py_sqlite3_talker"),  # std_msgs/String
        ("logs", "mcap_conformance", "TenMessages", "TenMessages-ch-chx-mx-pad-rch.mcap"),
    ],
    ids=["turtlesim", "no-messages", "talker", "not-ros"],
)
def test_a_log_without_people_gets_no_advice_on_its_graph(
    parts: tuple[str, ...], tmp_path: Path
) -> None:
    log = real(*parts)
    result = run("info", log)
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split())
    assert "`aion build` cannot learn flows from this log" in said, said
    assert NO_GRAPH not in said, said
    # and what the note advised does not build it: the build refuses the log
    built = run("build", log, "--derive-graph", "-o", tmp_path / "m.aion", "-q")
    assert built.exit_code == 2, built.stderr
    assert built.stderr.startswith("error: "), built.stderr


def test_a_log_with_people_and_no_graph_keeps_the_note() -> None:
    log = real("logs", "leg_tracker", "positive_2_extracted.bag")  # /leg_cluster_positions
    result = run("info", log)
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split())
    assert "cannot learn flows" not in said, said
    assert NO_GRAPH in said, said
