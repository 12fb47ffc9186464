"""Detections faster than people: a build warns when its detections' mean speed is beyond what
people walk (``build_plausibility.PLAUSIBLE_SPEED_M_S``), because their times or positions
cannot be what they seem — the real case is a leg-tracker bag re-recorded in half a second whose
PoseArrays carry no header stamps (``../shared/data/logs/leg_tracker``). The walker here moves
0.5 m per message and carries no velocity, so its speeds come from its track: at 2 messages a
second it walks 1 m/s; with the same messages 10 ms apart it "moves" 50 m/s.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from aion_cli.build_plausibility import FAST_PEOPLE_WARNING, fast_people_warning
from aion_cli.build_report import BuildReport
from aion_cli.shard_reports import combine_reports
from tests.robustness.conftest import T0, Message, S, build_json, person, write_log
from tests.shared_data import real


def still_walker(n: int, step_ns: int) -> list[Message]:
    """``n`` messages ``step_ns`` apart of one person 0.5 m further along +x each time, with
    a zero twist (no velocity: the heading and speed come from the track)."""
    out = []
    for k in range(n):
        topic, msgtype, msg, t_ns = person(T0 + k * step_ns, (0.5 * k, 1.0, 0.0))
        msg["tracks"][0]["twist"]["twist"]["linear"]["x"] = 0.0
        out.append((topic, msgtype, msg, t_ns))
    return out


def fast_warnings(report: dict[str, Any]) -> list[str]:
    return [w for w in report["warnings"] if w.startswith(FAST_PEOPLE_WARNING)]


def test_a_walker_at_walking_speed_is_not_warned_about(tmp_path: Path) -> None:
    log = write_log(tmp_path / "walk.mcap", still_walker(60, S // 2))
    report = build_json(log, "-o", tmp_path / "walk.aion")
    assert report["mean_speed_m_s"] == pytest.approx(1.0, rel=0.05)
    assert fast_warnings(report) == []


def test_the_same_walker_ten_milliseconds_apart_is_warned_about(tmp_path: Path) -> None:
    log = write_log(tmp_path / "fast.mcap", still_walker(60, S // 100))
    report = build_json(log, "-o", tmp_path / "fast.aion")
    assert report["mean_speed_m_s"] == pytest.approx(50.0, rel=0.05)
    (line,) = fast_warnings(report)
    assert line.startswith(f"{FAST_PEOPLE_WARNING}{report['mean_speed_m_s']:,.1f} m/s on average")


def test_the_warning_depends_on_the_mean_only() -> None:
    report = BuildReport(output=Path("x.aion"))
    assert fast_people_warning(report) is None  # no speed at all
    report.speed_micro, report.speed_n = 3_000_000 * 1000, 1000
    assert fast_people_warning(report) is None  # 3 m/s: a running crowd
    report.speed_micro = 3_010_000 * 1000
    line = fast_people_warning(report)
    assert line is not None
    assert line.startswith(f"{FAST_PEOPLE_WARNING}3.0 m/s")
    assert "1,000 detections with a speed" in line


def test_a_parallel_build_warns_once_from_the_shards_sums() -> None:
    """Two shards: one fast, one slow; the parent's report warns once, from the sums (which
    a sequential build of both would see), not with either shard's own line."""
    fast, slow = BuildReport(output=Path("a")), BuildReport(output=Path("b"))
    fast.speed_micro, fast.speed_n = 40_000_000 * 100, 100
    slow.speed_micro, slow.speed_n = 1_000_000 * 100, 100
    for part in (fast, slow):
        line = fast_people_warning(part)
        if line is not None:
            part.warnings.append(line)
    assert len(fast.warnings) == 1
    out = BuildReport(output=Path("out"))
    combine_reports(out, [fast, slow])
    assert (out.speed_micro, out.speed_n) == (4_100_000_000, 200)
    (line,) = [w for w in out.warnings if w.startswith(FAST_PEOPLE_WARNING)]
    assert line.startswith(f"{FAST_PEOPLE_WARNING}20.5 m/s")
    slow_only = BuildReport(output=Path("out"))
    combine_reports(slow_only, [slow, BuildReport(output=Path("c"))])
    assert not [w for w in slow_only.warnings if w.startswith(FAST_PEOPLE_WARNING)]


def test_a_leg_tracker_bag_recorded_in_half_a_second_is_warned_about(tmp_path: Path) -> None:
    """The real case: 197 PoseArrays without header stamps in 0.48 s of log time."""
    bag = real("logs", "leg_tracker", "positive_1_extracted.bag")
    report = build_json(bag, "--map-frame", "right_laser", "-o", tmp_path / "leg.aion")
    assert report["mean_speed_m_s"] > 10.0
    assert len(fast_warnings(report)) == 1
