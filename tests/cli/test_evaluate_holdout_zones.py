"""``aion evaluate holdout`` on the corridor of :mod:`tests.cli.test_evaluate_holdout`: a test
log that declares another time zone than the map's (``aion simulate --tz``, ``aion convert
--tz``) is warned of, as ``aion build`` warns of one."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import run, run_json
from tests.cli.test_evaluate_holdout import DAY, HOUR, MONDAY, S, corridor, write_days

__all__ = ["corridor"]  # the fixture, built once for this module


def test_a_test_log_in_another_zone_is_warned_of(corridor: tuple, tmp_path: Path) -> None:
    """The map follows UTC; the held-out day, converted with --tz Asia/Tokyo, declares that
    its people keep Tokyo's hours. It was scored in silence (its hours judged 9 h off the
    map's rhythm, nothing saying why); a warning names the log and both zones now. The same
    day declaring UTC, the map's zone, gets none."""
    site, _train, _test, _truth = corridor
    write_days(tmp_path / "tokyo.csv", 6, 1)
    lo, hi = MONDAY + 6 * DAY + 8 * HOUR, MONDAY + 6 * DAY + 18 * HOUR
    span = f"{lo / S:.0f}..{hi / S:.0f}"
    logs = {}
    for zone in ("Asia/Tokyo", "UTC"):
        log = tmp_path / f"{zone.replace('/', '-')}.mcap"
        made = run("convert", tmp_path / "tokyo.csv", "-o", log, "--observed", span,
                   "--tz", zone)  # fmt: skip
        assert made.exit_code == 0, made.stderr
        logs[zone] = log
    doc = run_json("evaluate", "holdout", site, logs["Asia/Tokyo"], "--format", "json")
    assert doc["test"]["timezone"] == "UTC"
    assert doc["warnings"] == [
        "Asia-Tokyo.mcap declares the time zone Asia/Tokyo (written by aion simulate or convert "
        "--tz), but the map follows UTC: the scene's hours are judged against the map's, off "
        "wherever the two zones' clocks differ"
    ]
    said = run("evaluate", "holdout", site, logs["Asia/Tokyo"], "-q")
    assert said.exit_code == 0, said.stderr
    assert "warning: Asia-Tokyo.mcap declares the time zone Asia/Tokyo" in said.stderr
    same = run_json("evaluate", "holdout", site, logs["UTC"], "--format", "json")
    assert same["warnings"] == []
