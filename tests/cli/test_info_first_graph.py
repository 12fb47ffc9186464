"""``aion info`` describes a scene-graph topic by the first graph ``aion build`` uses
(build_lineage.first_used_graph), not by the topic's raw first message."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import run_json
from tests.cli.logdata import write_office_log

TOPIC = "/hydra/backend/dsg"


def test_a_stray_first_graph_message_does_not_describe_the_topic(tmp_path: Path) -> None:
    """A damaged DsgUpdate logged two days before the rest (a stray log time the build
    drops) made info say 'spark_dsg unreadable: cannot decode scene-graph payload' for a
    topic whose every graph the build uses decodes. Now the topic is described by its first
    kept graph, as the same log without the stray is, and a warning says one message before
    it was left out."""
    plain = tmp_path / "plain.mcap"
    write_office_log(plain, "mcap")
    stray = tmp_path / "stray.mcap"
    write_office_log(stray, "mcap", early_graph=(2 * 86_400, b"\x00damaged"))
    want = run_json("info", plain, "--format", "json")
    got = run_json("info", stray, "--format", "json")
    assert not want["dsg_versions"][TOPIC][0].startswith("unreadable"), want["dsg_versions"]
    assert got["dsg_versions"][TOPIC] == want["dsg_versions"][TOPIC]
    said = [w for w in got["warnings"] if w.startswith(f"{TOPIC}: described by the first")]
    assert len(said) == 1, got["warnings"]
    assert "1 graph message(s) before it left out" in said[0]
    assert not any("described by the first" in w for w in want["warnings"]), want["warnings"]
