"""Time shards of a tracker that publishes empty messages: quiet moments found by decoding
(where the index sees messages everywhere), and not searched where reading is slow."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.logdata import T0, S
from tests.time_shard_logs import (
    HOUR_S,
    build_logs,
    same_maps,
    same_reports,
)


def _fixed_rate(path: Path, container: str = "mcap") -> Path:
    """A tracker publishing every 5 s from Monday 08:00 to 10:20, empty messages included:
    the office's people from 08:00 to 08:20 and from 10:00 to 10:20, nobody in between."""
    from aion_cli.formats.writers import LogWriter
    from tests.cli.logdata import _tracked_persons

    sessions = (T0, T0 + 2 * HOUR_S * S)
    with LogWriter(path, container) as writer:
        for k in range((2 * HOUR_S + 1200) // 5):
            t = T0 + 5 * k * S
            start = max(s for s in sessions if s <= t)
            message = (
                _tracked_persons(t, start, "map")
                if t - start < 1200 * S
                else {"header": {"stamp": {"sec": t // S, "nanosec": 0}, "frame_id": "map"},
                      "tracks": []}
            )
            writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons", message, t)
    return path


@pytest.mark.parametrize(
    ("container", "name"),
    [("mcap", "log.mcap"), ("bag", "log.bag"), ("rosbag2-sqlite3", "log"), ("rosbag2-mcap", "log")],
)
def test_a_tracker_publishing_empty_messages_is_cut_where_decoding_finds_nobody(
    tmp_path: Path, container: str, name: str
) -> None:
    # its messages never pause, so the index shows no quiet moment; decoding the 10 s before
    # the window starts nearest the even split finds them empty (an indexed MCAP reads just
    # those seconds' chunks, a ROS 1 bag finds them in its index, rosbag2's storage files
    # select them themselves)
    log = _fixed_rate(tmp_path / name, container)
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = build_logs([log], seq, 1)
    two = build_logs([log], par, 2)
    assert [(r["from"], r["to"]) for r in two.workers] == [
        ("start", "2026-11-23 09:10:00 UTC"),  # half of the messages on either side
        ("2026-11-23 09:10:00 UTC", "end"),
    ]
    assert same_maps(seq, par) == []
    same_reports(one, two)


def test_quiet_moments_only_decoding_finds_are_not_searched_where_reading_is_slow(
    tmp_path: Path,
) -> None:
    # a log read from its start for every moment probed (an MCAP without its chunk index:
    # here a truncated copy, as a robot that lost power leaves it) is not probed: built in
    # one process, and the build says why, naming that log (it used to say only that there
    # was no quiet moment, which the intact log alone has, as the first test shows)
    log = _fixed_rate(tmp_path / "log.mcap")
    data = log.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 9 // 10])
    report = build_logs([cut], tmp_path / "par.aion", 2)
    assert report.workers == []
    reason = [n for n in report.notes if "not cut into time shards" in n]
    assert len(reason) == 1, report.notes
    assert reason[0].startswith("cut.mcap: not cut into time shards: no pause")
    assert "cut.mcap has no chunk index (truncated" in reason[0]
    assert not any("no quiet moment" in n for n in report.notes)
    intact = build_logs([log], tmp_path / "intact.aion", 2)
    assert len(intact.workers) == 2  # the log itself is cut where decoding finds nobody
