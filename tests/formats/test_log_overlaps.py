"""What files of a log set carry at the same time (:mod:`formats.log_overlaps`).

:func:`find_overlaps` (same topics at once: two copies of one recording?) and
:func:`topics_at_once` (other topics at once: two scene-graph streams?) both compare what each
file carries: the asked-for topics it holds messages of. They used to compute that apart; the
logs below are laid out so that either one reading a file's topics otherwise (counting an
asked-for topic the file declares without a message, or a topic not asked for) gives another
answer than the hand-computed one."""

from __future__ import annotations

from pathlib import Path

from aion_cli.formats.log_overlaps import find_overlaps, topics_at_once
from aion_cli.formats.logs import open_logs
from aion_cli.formats.writers import LogWriter

S = 1_000_000_000
STRING = "std_msgs/msg/String"
ASKED = {"/g1", "/g2"}


def _log(path: Path, spans: dict[str, tuple[int, int]], empty: str | None = None) -> Path:
    """A log with one message every 10 s on each topic of ``spans`` over its ``(from, to)``
    seconds (both ends included), and ``empty`` declared without any message."""
    with LogWriter(path, "mcap") as writer:
        if empty is not None:
            writer._channel(empty, STRING)  # a channel the index lists with count 0
        times = sorted((t, topic) for topic, (lo, hi) in spans.items()
                       for t in range(lo, hi + 1, 10))
        for t, topic in times:
            writer.write(topic, STRING, {"data": topic}, t * S)
    return path


def _logs(tmp_path: Path, with_e: bool) -> list[Path]:
    """a and b on /g1 at once (50-100 s); c and d on /g2 at once (350-400 s); b declares /g2
    without a message; a, c and d also carry /noise (not asked for). ``with_e``: e on /g2
    at 60-90 s, at the same time as a and b's /g1."""
    logs = [
        _log(tmp_path / "a.mcap", {"/g1": (0, 100), "/noise": (0, 100)}),
        _log(tmp_path / "b.mcap", {"/g1": (50, 150)}, empty="/g2"),
        _log(tmp_path / "c.mcap", {"/g2": (300, 400), "/noise": (300, 400)}),
        _log(tmp_path / "d.mcap", {"/g2": (350, 450), "/noise": (350, 450)}),
    ]
    if with_e:
        logs.append(_log(tmp_path / "e.mcap", {"/g2": (60, 90)}))
    return logs


def _found(paths: list[Path]) -> tuple[list[tuple[tuple[int, int], tuple[str, ...], int, int]],
                                        list[str]]:
    with open_logs(paths) as logset:
        overlaps = [(o.pair, o.topics, o.start_ns // S, o.end_ns // S)
                    for o in find_overlaps(logset, ASKED, 1)]
        return overlaps, topics_at_once(logset, ASKED)


def test_both_read_what_a_file_carries_alike(tmp_path: Path) -> None:
    """Only a and b share a topic at once (/g1, 50-100 s) and c and d (/g2, 350-400 s):
    /noise is not asked for, b's /g2 holds nothing. No two files carry other asked-for
    topics at once, and no file carries two: no graph streams at once."""
    overlaps, at_once = _found(_logs(tmp_path, with_e=False))
    assert overlaps == [((0, 1), ("/g1",), 50, 100), ((2, 3), ("/g2",), 350, 400)]
    assert at_once == []  # b's empty /g2 would make it ["/g1", "/g2"], /noise add "/noise"


def test_both_agree_on_a_file_on_another_topic_at_once(tmp_path: Path) -> None:
    """e's /g2 runs at the same time as a and b's /g1: two streams at once for
    :func:`topics_at_once`, and for :func:`find_overlaps` no pair (e shares no topic with
    a, nor with b, whose /g2 holds nothing)."""
    overlaps, at_once = _found(_logs(tmp_path, with_e=True))
    assert overlaps == [((0, 1), ("/g1",), 50, 100), ((2, 3), ("/g2",), 350, 400)]
    assert at_once == ["/g1", "/g2"]
