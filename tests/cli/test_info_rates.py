"""A topic's rate in ``aion info`` of several logs was its count over the whole span from the
first log's first message to the last log's last, the days between two recordings included:
the office log on Monday and on Wednesday showed /tf at a 100th of the rate each log recorded
it at. The rate is now over the time the logs holding the topic recorded; computed here from
the mcap library's own reading of each file (counts, first and last log times)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
from mcap.reader import make_reader

from tests.cli.conftest import run_json
from tests.cli.logdata import write_office_log
from tests.shared_data import real

DAY_S = 86_400


def _read(path: Path) -> tuple[Counter[str], int, int]:
    with path.open("rb") as f:
        times, topics = [], Counter[str]()
        for _, channel, message in make_reader(f).iter_messages():
            topics[channel.topic] += 1
            times.append(message.log_time)
    return topics, min(times), max(times)


def test_rates_over_the_time_recorded_not_the_days_between(tmp_path: Path) -> None:
    monday, wednesday = tmp_path / "monday.mcap", tmp_path / "wednesday.mcap"
    write_office_log(monday)
    write_office_log(wednesday, shift_s=2 * DAY_S)
    (mon, mon_first, mon_last), (wed, wed_first, wed_last) = _read(monday), _read(wednesday)
    recorded_s = ((mon_last - mon_first) + (wed_last - wed_first)) / 1e9
    assert wed_first - mon_last > DAY_S * 1e9  # a day and more between the two

    one = run_json("info", monday, "--format", "json")
    for t in one["topics"]:  # one log: its count over its span (unchanged)
        if mon[t["topic"]] > 1:
            expected = mon[t["topic"]] / ((mon_last - mon_first) / 1e9)
            assert t["rate_hz"] == pytest.approx(expected, rel=6e-3)  # JSON: 3 digits
    both = run_json("info", monday, wednesday, "--format", "json")
    rates = {t["topic"]: t["rate_hz"] for t in both["topics"]}
    assert set(rates) == set(mon) | set(wed)
    for topic, rate in rates.items():
        count = mon[topic] + wed[topic]
        assert count > 1
        assert rate == pytest.approx(count / recorded_s, rel=6e-3), topic


def test_a_bag_split_into_files_has_the_rates_of_its_sqlite3_twin() -> None:
    """rosbag2's own test bag of five mcap storage files (and its twin of five sqlite3 files,
    the same 6,074 messages): the time between two files of one bag was recorded too. The
    mcap bag's rates left out those gaps (AAA at 403,007,519 Hz against the twin's
    402,402,402); now both are a topic's count over the bag's first to last message, read
    here with the mcap library (JSON keeps three decimals of these 10^8 Hz: 1e-9 relative)."""
    mcap_bag = real("logs", "rosbag2_tests", "rosbag2_py_mcap_wbag")
    sqlite_bag = real("logs", "rosbag2_tests", "rosbag2_py_sqlite3_wbag")
    counts, firsts, lasts = Counter[str](), [], []
    for part in sorted(mcap_bag.glob("*.mcap")):
        topics, first, last = _read(part)
        counts.update(topics)
        firsts.append(first)
        lasts.append(last)
    assert len(firsts) == 5
    span_s = (max(lasts) - min(firsts)) / 1e9
    for bag in (mcap_bag, sqlite_bag):
        rates = {t["topic"]: t["rate_hz"] for t in run_json("info", bag, "--format", "json")
                 ["topics"]}  # fmt: skip
        assert set(rates) == set(counts)
        for topic, rate in rates.items():
            assert rate == pytest.approx(counts[topic] / span_s, rel=1e-9), (bag.name, topic)
