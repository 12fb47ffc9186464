"""``aion info LOG`` names the time zone a log declares (``aion simulate --tz``): a ROS 1 bag
showed it only as its ``/aion/timezone`` topic, and an MCAP file or a rosbag2 folder (which
keep it in their metadata) not at all, though ``aion build`` follows it without ``--tz``."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import run, run_json


@pytest.mark.parametrize("container", ["mcap", "rosbag2"])
def test_info_names_the_zone_simulate_wrote(tmp_path: Path, container: str) -> None:
    log = tmp_path / ("tokyo.mcap" if container == "mcap" else "tokyo")
    made = run("simulate", "-o", log, "--days", "0.001", "--agents", "1", "--tz", "Asia/Tokyo",
               "--format", container, "-q")  # fmt: skip
    assert made.exit_code == 0, made.stderr
    doc = run_json("info", log, "--format", "json")
    assert doc["declared_zones"] == {str(log): "Asia/Tokyo"}
    table = run("info", log)
    assert table.exit_code == 0, table.stderr
    said = " ".join(table.stderr.split())
    assert (f"note: {log.name} declares its time zone (aion simulate or convert --tz), the one "
            "of the times here: `aion build` follows it") in said
    assert " Asia/Tokyo)" in " ".join(table.stdout.split())  # the header's times: said once
    other = run("info", log, "--tz", "UTC")
    assert f"note: {log.name} declares the time zone Asia/Tokyo" in other.stderr


def test_a_fixed_sensors_hours_are_in_the_zone_the_log_declares(tmp_path: Path) -> None:
    """A log converted with ``--tz Europe/Berlin`` is built in Berlin's hours without
    ``--tz``, so ``info`` without ``--tz`` gives its hours with messages in Berlin's hours too
    (it gave them in UTC: 06:00-07:00 where the map the build then wrote says 07:00-08:00);
    ``--tz UTC`` still gives UTC's. People walk 07:00-07:20 Berlin time on Friday
    2026-03-27 (06:00 UTC, computed here with zoneinfo)."""
    from datetime import datetime
    from zoneinfo import ZoneInfo

    start = int(datetime(2026, 3, 27, 7, 0, tzinfo=ZoneInfo("Europe/Berlin")).timestamp())
    rows = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    rows += [f"{(start + k) * 10**9},1,{k * 0.01:.2f},0.0,0.0,0.0,1.0" for k in range(0, 1200, 2)]
    csv = tmp_path / "morning.csv"
    csv.write_text("\n".join(rows) + "\n")
    log = tmp_path / "morning.mcap"
    converted = run("convert", csv, "-o", log, "--tz", "Europe/Berlin", "-q")
    assert converted.exit_code == 0, converted.stderr
    doc = run_json("info", log, "--format", "json")
    assert doc["fixed_sensor"]["hours_with_messages"] == (
        "weekdays 07:00-08:00; weekends none (Europe/Berlin)"
    )
    utc = run_json("info", log, "--tz", "UTC", "--format", "json")
    assert utc["fixed_sensor"]["hours_with_messages"] == "weekdays 06:00-07:00; weekends none (UTC)"
    built = run("build", log, "-o", tmp_path / "morning.aion", "--derive-graph", "-q")
    assert built.exit_code == 0, built.stderr
    table = run("info", tmp_path / "morning.aion")
    shown = " ".join(table.stdout.split())
    assert "weekdays 07:00-08:00; weekends none " in shown  # the zone: named by the time span
    # the time span's, the created row's (458587a5) and the config row's timezone
    assert shown.count("Europe/Berlin") == 3


def test_logs_that_declare_one_zone_get_one_note(tmp_path: Path) -> None:
    """``aion info`` of several logs converted with one ``--tz`` repeated the same note once
    per log (five Lincoln days: five lines alike); the logs that declare one zone share a
    note now, and a log of another zone has its own."""
    logs = []
    zones = ("Europe/Berlin", "Europe/Berlin", "Asia/Tokyo")
    for hour, (name, tz) in enumerate(zip("abc", zones, strict=True)):  # an hour apart
        csv = tmp_path / f"{name}.csv"
        csv.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n"
                       f"{1774594800 + 3600 * hour}000000000,1,0.0,0.0,0.0,0.0,1.0\n")
        logs.append(tmp_path / f"{name}.mcap")
        converted = run("convert", csv, "-o", logs[-1], "--tz", tz, "-q")
        assert converted.exit_code == 0, converted.stderr
    both = run("info", logs[0], logs[1])
    assert both.exit_code == 0, both.stderr
    said = [line for line in both.stderr.splitlines() if " declare" in line]
    assert said == ["note: a.mcap and b.mcap declare their time zone (aion simulate or convert "
                    "--tz), the one of the times here: `aion build` follows it unless --tz is "
                    "given"]
    three = run("info", *logs, "--tz", "UTC")
    said = [line for line in three.stderr.splitlines() if " declare" in line]
    assert said == [
        "note: a.mcap and b.mcap declare the time zone Europe/Berlin (aion simulate or convert "
        "--tz): `aion build` follows it unless --tz is given",
        "note: c.mcap declares the time zone Asia/Tokyo (aion simulate or convert --tz): "
        "`aion build` follows it unless --tz is given",
    ]
