"""``aion convert --observed``'s summary: its first line said "in 20 messages" while the
"observed:" line counted the empty marker messages beside them ("marked by 21 empty detection
messages"), so the two did not add up to what the log holds. The first line now names the
empty ones too; both are checked against the messages the written MCAP holds (read with the
mcap library), and a log without spans says nothing of empty messages."""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

from mcap.reader import make_reader

from tests.cli.conftest import run

T0 = 1_795_420_800 * 10**9  # 2026-11-23 08:00:00 UTC
S = 10**9


def _tracks(path: Path, n: int = 20) -> Path:
    """One person walking +x at 1 m/s, one row a second from 08:00:00 (canonical CSV)."""
    rows = [f"{T0 + k * S},1,{0.1 * k:.2f},0.0,0.0,0.0,1.0" for k in range(n)]
    path.write_text("\n".join(["t_ns,track_id,x,y,z,heading_rad,speed_mps", *rows]) + "\n")
    return path


def _messages(log: Path) -> Counter[str]:
    with log.open("rb") as f:
        reader = make_reader(f)
        return Counter(channel.topic for _, channel, _ in reader.iter_messages())


def test_the_summary_counts_the_empty_marker_messages_the_observed_line_counts(
    tmp_path: Path,
) -> None:
    tracks, log = _tracks(tmp_path / "t.csv"), tmp_path / "t.mcap"
    result = run("convert", tracks, "-o", log, "--observed",
                 "2026-11-23 07:50..2026-11-23 08:10")  # fmt: skip
    assert result.exit_code == 0, result.stderr
    text = " ".join(result.output.split())
    wrote = re.search(r"20 detections of 1 track in 20 messages \(and ([\d,]+) empty\) over", text)
    assert wrote is not None, text
    marked = re.search(r"marked by ([\d,]+) empty detection messages", text)
    assert marked is not None, text
    assert wrote.group(1) == marked.group(1)
    (topic, held), *_ = _messages(log).most_common()  # the detection topic
    assert held == 20 + int(marked.group(1).replace(",", "")), topic
    # 20 minutes marked every 30 s and at the last instant: 41 stamps
    assert int(marked.group(1)) == 41


def test_a_log_without_spans_counts_no_empty_messages(tmp_path: Path) -> None:
    tracks, log = _tracks(tmp_path / "t.csv"), tmp_path / "t.mcap"
    result = run("convert", tracks, "-o", log)
    assert result.exit_code == 0, result.stderr
    text = " ".join(result.output.split())
    assert "20 detections of 1 track in 20 messages over 19 s" in text, text
    assert "empty)" not in text
    assert max(_messages(log).values()) == 20
