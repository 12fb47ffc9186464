"""Time shards and the orientation rule: a part built apart must set pose orientations aside
(or keep them) exactly as one pass does at that point of the log, or be learnt in sequence;
the maps are compared with the sequential build's (``tests/time_shard_logs.py``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.logdata import T0
from tests.time_shard_logs import (
    HOUR_S,
    build_logs,
    same_maps,
    second_part_in_sequence,
    standing_log,
)


def test_orientations_judged_alike_at_a_part_start_join_once_the_plan_saw_them_vary(
    tmp_path: Path,
) -> None:
    # aion sets aside pose orientations that have never varied (a tracker leaving them at
    # identity). The morning's two people face apart, so one pass keeps every yaw after it;
    # the evening's one person, alone, faces one way: a part starting there, judged from
    # scratch, would set the yaw aside. The plan reads the first messages, sees the
    # orientations vary in the morning, and starts the evening's part as one pass reaches
    # it: the parts join in parallel into the map of one pass.
    log = standing_log(tmp_path / "log.mcap", [(0, [0.0, 1.5]), (10 * HOUR_S, [0.7])])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = build_logs([log], seq, 1)
    two = build_logs([log], par, 2)
    assert len(two.workers) == 2
    assert not [n for n in two.notes if "in sequence" in n]
    assert same_maps(seq, par) == []
    assert one.headings == two.headings
    assert one.headings.get("pose_yaw", 0) == 120 * 3  # every yaw kept, the evening's too


def test_a_later_log_starts_with_the_orientations_of_the_logs_before(tmp_path: Path) -> None:
    # The same across two logs a day apart (two shards of logs, not of time): the second
    # log's one person would lose the yaw judged alone; the plan starts it as one pass does.
    first = standing_log(tmp_path / "a.mcap", [(0, [0.0, 1.5])])
    second = standing_log(tmp_path / "b.mcap", [(30 * HOUR_S, [0.7])])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = build_logs([first, second], seq, 1)
    two = build_logs([first, second], par, 2)
    assert len(two.workers) == 2
    assert not [n for n in two.notes if "in sequence" in n]
    assert same_maps(seq, par) == []
    assert one.headings.get("pose_yaw", 0) == two.headings.get("pose_yaw", 0) == 120 * 3


def test_logs_that_start_in_a_continued_maps_open_window_are_learnt_in_sequence(
    tmp_path: Path,
) -> None:
    # The map's last message and the new logs' first fall in one window: one pass continues
    # that window with the new messages, which a join cannot (before: an internal error).
    # The first group is learnt in sequence onto the map, the later one joins.
    first = standing_log(tmp_path / "a.mcap", [(0, [0.0, 1.5])])  # messages 5 .. 1195 s
    second = standing_log(tmp_path / "b.mcap", [(1192, [0.3, 1.0])])  # from 1197 s
    third = standing_log(tmp_path / "c.mcap", [(30 * HOUR_S, [0.7, 2.0])])
    base = tmp_path / "base.aion"
    build_logs([first], base, 1)
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    build_logs([second, third], seq, 1, continue_from=base)
    two = build_logs([second, third], par, 2, continue_from=base)
    assert len(two.workers) == 2
    notes = [n for n in two.notes if "in sequence" in n]
    assert len(notes) == 1
    assert "b.mcap was learnt" in notes[0]
    assert "a time window the map before them had already recorded" in notes[0]
    assert same_maps(seq, par) == []


def test_orientations_the_plan_did_not_read_are_learnt_in_sequence(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The same log with the plan's scan switched off: the evening's part is judged from
    # scratch, the join sees that it set a yaw aside that one pass keeps, and learns the part
    # in sequence, continuing the rule's state: the map of one pass.
    import aion_cli.shard_yaws

    monkeypatch.setattr(aion_cli.shard_yaws, "SCAN_MESSAGES", 0)
    log = standing_log(tmp_path / "log.mcap", [(0, [0.0, 1.5]), (10 * HOUR_S, [0.7])])
    one, two = second_part_in_sequence(tmp_path, log, "orientations on /tracks")
    assert one.headings == two.headings
    assert one.headings.get("pose_yaw", 0) == 120 * 3


def test_a_wrong_orientation_assumption_is_caught_at_the_join(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # One person facing one way all day: one pass sets every yaw aside. A plan that wrongly
    # claims the orientations varied at the start would make the evening's part keep its
    # yaws; the join checks the claim against the state the morning's part left, and learns
    # the part in sequence instead: the map of one pass, no yaw kept.
    import aion_cli.shard_yaws

    wrong = {"/tracks": T0}
    monkeypatch.setattr(aion_cli.shard_yaws, "varied_by", lambda logset, plan, opts: wrong)
    log = standing_log(tmp_path / "log.mcap", [(0, [0.7]), (10 * HOUR_S, [0.7])])
    one, two = second_part_in_sequence(tmp_path, log, "started as if the pose orientations")
    assert one.headings == two.headings
    assert one.headings.get("pose_yaw", 0) == 0


def test_orientations_that_vary_in_every_part_join_in_parallel(tmp_path: Path) -> None:
    log = standing_log(tmp_path / "log.mcap", [(0, [0.0, 1.5]), (10 * HOUR_S, [0.7, -1.0])])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    build_logs([log], seq, 1)
    two = build_logs([log], par, 2)
    assert len(two.workers) == 2
    assert not [n for n in two.notes if "in sequence" in n]
    assert same_maps(seq, par) == []
