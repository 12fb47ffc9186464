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
