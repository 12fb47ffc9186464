"""build_lineage.first_used_graph on a log whose index cannot give the graph times: the
first graph messages settle it where they can (no pass over every graph), with the answer
the whole log's times give."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.cli.logdata import write_office_log

TOPIC = "/hydra/backend/dsg"


def _first(log: Path, indexed: bool, monkeypatch: pytest.MonkeyPatch) -> tuple[int, int, int]:
    """(log time of the first graph used, messages passed over, graph messages read)."""
    from aion_cli.build_lineage import first_used_graph
    from aion_cli.build_report import BuildReport
    from aion_cli.formats.logs import LogSet, open_logs
    from aion_cli.graph_feed import GraphFeed

    read = [0]
    real = LogSet.messages

    def counted(self: LogSet, *args: Any, **kwargs: Any) -> Iterator[Any]:
        for msg in real(self, *args, **kwargs):
            read[0] += msg.topic == TOPIC
            yield msg

    with monkeypatch.context() as m:
        m.setattr(LogSet, "messages", counted)
        if not indexed:  # as for a log whose index cannot say (payloads zstd one by one)
            m.setattr(LogSet, "index_times", lambda self, topics, vouch=True: None)
        with open_logs([log], None) as logset:
            feed = GraphFeed(BuildReport(Path()), None, None, 0)
            used = first_used_graph([log], None, logset, {TOPIC}, lambda x: feed.peek(logset, x))
            assert used is not None
            return used.msg.log_time_ns, used.passed, read[0]


@pytest.mark.parametrize(
    ("case", "kwargs"),
    [
        ("plain", {"duration_s": 3600}),  # 60 graphs
        ("stray first", {"early_graph": (2 * 86_400, b"\x00damaged")}),
        ("damaged first", {"early_graph": (1, b"\x00damaged")}),
        ("few graphs", {"duration_s": 300}),  # 5 graphs: none is ever a stray
    ],
)
def test_first_used_graph_without_index_is_decided_as_with_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, case: str, kwargs: dict[str, Any]
) -> None:
    log = tmp_path / "log.mcap"
    write_office_log(log, "mcap", **kwargs)
    t_idx, passed_idx, _ = _first(log, True, monkeypatch)
    t_raw, passed_raw, read = _first(log, False, monkeypatch)
    assert (t_raw, passed_raw) == (t_idx, passed_idx)
    assert passed_idx == (0 if case in ("plain", "few graphs") else 1)
    if case == "plain":  # the first 44 graph messages settle it: not all 60 read
        assert read <= 44, read
