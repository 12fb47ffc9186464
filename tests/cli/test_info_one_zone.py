"""``aion info`` shows every time of a log, and of a map, on one clock and names its zone
once: the zone a build follows (the one the log declares, or ``--tz``, else UTC). Before,
``info LOG`` gave a fixed sensor's hours with messages in the declared zone but its span and
its observed spans in UTC beside them, and ``info MAP`` its time span in the map's zone but
``created`` in UTC. JSON keeps its values (UNIX ns, UTC ISO times) and keys.

The log: ATC-like rows from 1351038020 (2012-10-24 00:20:20 UTC = 09:20:20 in Tokyo, UTC+9
without summer time) converted with ``--observed "2012-10-24 09:00..2012-10-24 21:00" --tz
Asia/Tokyo`` (00:00..12:00 UTC)."""

from __future__ import annotations

import re
from datetime import datetime
from pathlib import Path
from zoneinfo import ZoneInfo

from tests.cli.conftest import run, run_json

TOKYO = ZoneInfo("Asia/Tokyo")
FIRST_S = 1351038020  # 2012-10-24 00:20:20 UTC


def _log(tmp_path: Path, *zone: str) -> Path:
    rows = [f"{FIRST_S + k}.0,1,{k * 0.5:.1f},0.0,1.0,0.0" for k in range(40)]
    src = tmp_path / "atc.csv"
    src.write_text("\n".join(rows) + "\n")
    log = tmp_path / "atc.mcap"
    made = run("convert", src, "--layout", "atc", "-o", log, "--observed",
               "2012-10-24 09:00..2012-10-24 21:00", *zone, "-q")  # fmt: skip
    assert made.exit_code == 0, made.stderr
    return log


def _said(result: object) -> str:
    return " ".join((result.stdout + result.stderr).split())  # type: ignore[attr-defined]


def test_info_log_shows_every_time_in_the_declared_zone_named_once(tmp_path: Path) -> None:
    log = _log(tmp_path, "--tz", "Asia/Tokyo")
    table = run("info", log)
    assert table.exit_code == 0, table.stderr
    said = _said(table)
    assert said.count("Asia/Tokyo") == 1
    assert "UTC" not in said
    # the first message is the --observed marker at 09:00 Tokyo; the last, 1 ns before 21:00
    assert "(2012-10-24 09:00:00 .. 2012-10-24 20:59:59 Asia/Tokyo)" in said
    assert "observing (aion convert --observed): 2012-10-24 09:00:00 .. 2012-10-24 21:00:00;" \
        in said
    assert "hours with messages: weekdays 09:00-21:00; weekends none" in said
    doc = run_json("info", log, "--format", "json")  # JSON as before: UTC and UNIX ns
    (span,) = doc["observed_spans"][str(log)]
    assert span["start_ns"] == 1351036800 * 10**9
    assert span["start"] == "2012-10-24 00:00:00 UTC"
    assert doc["start"] == "2012-10-24T00:00:00.000000Z"
    assert doc["fixed_sensor"]["hours_with_messages"] == (
        "weekdays 09:00-21:00; weekends none (Asia/Tokyo)"
    )


def test_info_log_tz_shows_every_time_in_that_zone(tmp_path: Path) -> None:
    log = _log(tmp_path, "--tz", "Asia/Tokyo")
    said = _said(run("info", log, "--tz", "UTC"))
    assert "(2012-10-24 00:00:00 .. 2012-10-24 11:59:59 UTC)" in said
    assert "--observed): 2012-10-24 00:00:00 .. 2012-10-24 12:00:00;" in said
    assert "hours with messages: weekdays 00:00-12:00; weekends none" in said
    assert said.count(" UTC") == 1
    assert "declares the time zone Asia/Tokyo" in said  # the log's zone, not the times'


def test_a_log_without_a_zone_is_shown_in_utc_said_once(tmp_path: Path) -> None:
    log = _log(tmp_path)  # --observed read in UTC: 09:00..21:00 UTC
    said = _said(run("info", log))
    assert "(2012-10-24 00:20:20 .. 2012-10-24 20:59:59 UTC)" in said  # the first detection
    assert "--observed): 2012-10-24 09:00:00 .. 2012-10-24 21:00:00;" in said
    assert said.count("UTC") == 1


def test_info_map_agrees_with_info_log_on_one_clock(tmp_path: Path) -> None:
    log = _log(tmp_path, "--tz", "Asia/Tokyo")
    out = tmp_path / "atc.aion"
    built = run("build", log, "--derive-graph", "-o", out, "-q")
    assert built.exit_code == 0, built.stderr
    table = run("info", out)
    assert table.exit_code == 0, table.stderr
    rows = {}
    for line in table.stdout.splitlines():
        cells = [c.strip() for c in re.split(r"[│|]", line) if c.strip()]
        if len(cells) == 2:
            rows[cells[0]] = cells[1]
    assert rows["time span"] == "12h00m00s: Wed 2012-10-24 09:00 to Wed 2012-10-24 20:59 Asia/Tokyo"
    assert rows["hours observed"] == "weekdays 09:00-21:00; weekends none"
    created = run_json("info", out, "--format", "json")["created"]  # UTC, as before
    assert created.endswith("Z")
    local = datetime.fromisoformat(created).astimezone(TOKYO).strftime("%Y-%m-%d %H:%M:%S")
    assert rows["created"].startswith(f"{local} Asia/Tokyo by aion")  # its zone named
    outside_config = [text for what, text in rows.items() if what != "config"]
    named = [what for what, text in rows.items() if what != "config" and "Asia/Tokyo" in text]
    assert named == ["time span", "created"]  # the two times of day; hours observed are hours
    assert sum(text.count("Asia/Tokyo") for text in outside_config) == 2
    assert not any("UTC" in text or text.endswith("Z") for text in outside_config)
    # the log's span on the same clock: the same minutes as the map's
    header = _said(run("info", log))
    start, end = re.search(r"\((\S+ \S+) \.\. (\S+ \S+) Asia/Tokyo\)", header).groups()  # type: ignore[union-attr]
    assert (start[:16], end[:16]) == ("2012-10-24 09:00", "2012-10-24 20:59")


def test_info_log_warnings_give_their_times_on_the_same_clock(tmp_path: Path) -> None:
    """40 rows from 2012-10-24 00:20:20 UTC and one 400 days later (2013-11-28 00:20:20 UTC,
    09:20:20 in Tokyo, 01:20:20 in Berlin's winter), converted with ``--tz Asia/Tokyo``:
    info's warning about the stray time gave both its span and the stray time in UTC under a
    header in Asia/Tokyo. Now on the table's clock with its offset; ``--tz UTC`` and JSON
    as before."""
    rows = [f"{FIRST_S + k}.0,1,{k * 0.5:.1f},0.0,1.0,0.0" for k in range(40)]
    rows.append(f"{FIRST_S + 400 * 86_400}.0,2,1.0,0.0,1.0,0.0")
    src = tmp_path / "atc.csv"
    src.write_text("\n".join(rows) + "\n")
    log = tmp_path / "atc.mcap"
    made = run("convert", src, "--layout", "atc", "-o", log, "--tz", "Asia/Tokyo", "-q")
    assert made.exit_code == 0, made.stderr
    utc_warning = (
        "stray log time(s) left out of the span shown (2012-10-24 00:20:20 UTC .. "
        "2012-10-24 00:20:59 UTC): 1 on /people_tracker/tracked_persons (first: "
        "2013-11-28 00:20:20 UTC)"
    )
    table = _said(run("info", log))
    assert "(2012-10-24 09:20:20 .. 2012-10-24 09:20:59 Asia/Tokyo)" in table  # the header
    assert (
        "stray log time(s) left out of the span shown (2012-10-24 09:20:20+09:00 .. "
        "2012-10-24 09:20:59+09:00): 1 on /people_tracker/tracked_persons (first: "
        "2013-11-28 09:20:20+09:00)"
    ) in table
    assert "UTC" not in table
    berlin = _said(run("info", log, "--tz", "Europe/Berlin"))
    assert "(2012-10-24 02:20:20+02:00 .. 2012-10-24 02:20:59+02:00)" in berlin  # summer time
    assert "(first: 2013-11-28 01:20:20+01:00)" in berlin
    assert utc_warning in _said(run("info", log, "--tz", "UTC"))
    doc = run_json("info", log, "--format", "json")
    assert any(utc_warning in w for w in doc["warnings"]), doc["warnings"]
