"""A map's time zone: stored and kept by continuation, given twice it must agree, and one
zone in two spellings is one zone.

One zone, two spellings: a map whose ``--config`` names its zone ``+05:30`` and the command
line's ``--tz +05:30`` (read as UTC+05:30) are the same zone. The build refused to continue
such a map ("the map's days and profiles follow the time zone +05:30; --tz UTC+05:30
differs"), to take the config with the same --tz, and merge refused two such maps."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.errors import ConfigError
from tests.cli.conftest import Office, assert_one_line_error, run, run_json
from tests.cli.logdata import write_office_log
from tests.robustness.conftest import walk, write_log


@pytest.fixture
def logs(tmp_path: Path) -> tuple[Path, Path, Path]:
    first = write_log(tmp_path / "first.mcap", walk(300))
    later = write_log(tmp_path / "later.mcap", walk(300, start_s=7200))
    config = tmp_path / "india.toml"
    config.write_text('[model]\ntimezone = "+05:30"\n')
    return first, later, config


def ok(*args: str | Path) -> None:
    result = run(*args, "-q")
    assert result.exit_code == 0, result.stderr


def test_a_config_zone_and_the_same_tz_are_one_zone(
    logs: tuple[Path, Path, Path], tmp_path: Path
) -> None:
    first, later, config = logs
    ok("build", first, "-o", tmp_path / "a.aion", "--config", config)
    ok("build", later, "--map", tmp_path / "a.aion", "-o", tmp_path / "b.aion", "--tz", "+05:30")
    ok("build", first, "-o", tmp_path / "c.aion", "--config", config, "--tz", "UTC+05:30")
    ok("build", later, "-o", tmp_path / "d.aion", "--tz", "UTC+05:30")
    ok("merge", tmp_path / "a.aion", tmp_path / "d.aion", "-o", tmp_path / "m.aion")
    # a zone that differs is still refused
    other = run("build", later, "--map", tmp_path / "a.aion", "-o", tmp_path / "x.aion",
                "--tz", "+05:45")
    assert other.exit_code == 2
    assert "--tz UTC+05:45 differs" in other.stderr


@pytest.mark.parametrize(
    ("given", "key"),
    [("+05:30", "UTC+05:30"), ("utc+5:30", "UTC+05:30"), ("-0800", "UTC-08:00"), ("gmt", "UTC"),
     ("+00:00", "UTC"), ("europe/berlin", "Europe/Berlin"), ("Asia/Tokyo", "Asia/Tokyo")],
)
def test_a_config_records_its_zone_in_one_spelling(given: str, key: str) -> None:
    """A map's config (also one an older aion wrote, read back) names its zone as --tz does."""
    assert ModelConfig(timezone=given).timezone == key
    assert ModelConfig.from_dict({**ModelConfig().to_dict(), "timezone": given}).timezone == key


def test_time_zone_is_stored_and_kept_by_continuation(tmp_path: Path) -> None:
    """``--tz`` sets the model's zone (days and profile bins follow its clock); the manifest
    records it and a continued map refuses another zone with one error line."""
    day1, day2 = tmp_path / "day1.mcap", tmp_path / "day2.mcap"
    write_office_log(day1)
    write_office_log(day2, shift_s=86400)
    out = tmp_path / "london.aion"
    run_json("build", day1, "-o", out, "--tz", "Europe/London", "--format", "json")
    doc = run_json("info", out, "--format", "json")
    assert doc["config"]["timezone"] == "Europe/London"
    assert doc["timezone"] == "Europe/London"
    before = out.read_bytes()
    result = run("build", day2, "--map", out, "--tz", "Europe/Berlin")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "Europe/London", "Europe/Berlin")
    assert result.stdout == ""
    assert out.read_bytes() == before  # the map is untouched
    # the same zone (or none) continues the map
    cont = run_json("build", day2, "--map", out, "--tz", "Europe/London", "--format", "json")
    assert cont["continued"] is True
    assert run_json("info", out, "--format", "json")["config"]["timezone"] == "Europe/London"
    # without --tz a new map is in UTC
    run_json("build", day1, "-o", tmp_path / "utc.aion", "--format", "json")
    assert (
        run_json("info", tmp_path / "utc.aion", "--format", "json")["config"]["timezone"] == "UTC"
    )


def test_time_zone_given_twice_must_agree(tmp_path: Path) -> None:
    log = tmp_path / "day.mcap"
    write_office_log(log)
    config = tmp_path / "berlin.toml"
    config.write_text(ModelConfig(timezone="Europe/Berlin").to_toml())
    result = run(
        "build", log, "--config", config, "--tz", "Europe/London", "-o", tmp_path / "x.aion"
    )
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "Europe/London", "Europe/Berlin")
    assert not (tmp_path / "x.aion").exists()
    out = tmp_path / "y.aion"
    run_json(
        "build", log, "--config", config, "--tz", "Europe/Berlin", "-o", out, "--format", "json"
    )
    assert run_json("info", out, "--format", "json")["timezone"] == "Europe/Berlin"


@pytest.mark.parametrize("empty", ["", " "], ids=["empty", "blank"])
def test_an_empty_zone_is_worded_alike_by_every_command(
    office: Office, tmp_path: Path, empty: str
) -> None:
    """``--tz ""`` (an unset shell variable): simulate said "unknown time zone ''" where
    report, predict and build say "empty time zone"; a config's empty zone said it too."""
    said = {
        "simulate": run("simulate", "-o", tmp_path / "s.mcap", "--days", "0.1", "--tz", empty),
        "report": run("report", office.map, "-o", tmp_path / "r", "--tz", empty),
        "predict": run("predict", office.map, "--tz", empty),
    }
    for command, result in said.items():
        assert result.exit_code == 2, (command, result.stderr)
        assert_one_line_error(result.stderr, "error: empty time zone")
    assert said["simulate"].stderr == said["report"].stderr == said["predict"].stderr
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ConfigError, match=r"^empty time zone$"):
        ModelConfig(timezone=empty)


def test_another_name_of_the_maps_zone_continues_it(
    logs: tuple[Path, Path, Path], tmp_path: Path
) -> None:
    """Etc/UTC is UTC, Asia/Calcutta is Asia/Kolkata (links in the tz database). A map built
    in UTC continued with --tz Etc/UTC (or a --config naming it) was refused: "the map's days
    and profiles follow the time zone UTC; --tz Etc/UTC differs". The map is continued in its
    own zone and name, the map continuing it without --tz gives."""
    import zipfile

    def members(path: Path) -> dict[str, bytes]:
        with zipfile.ZipFile(path) as z:
            return {n: z.read(n) for n in z.namelist() if n != "manifest.json"}

    first, later, _ = logs
    etc = tmp_path / "etc.toml"
    etc.write_text('[model]\ntimezone = "Etc/UTC"\n')
    for zone, alias in (("UTC", "Etc/UTC"), ("Asia/Kolkata", "Asia/Calcutta")):
        base = tmp_path / f"{alias.replace('/', '_')}.aion"
        ok("build", first, "-o", base, "--tz", zone)
        ok("build", later, "--map", base, "-o", tmp_path / "plain.aion")
        ok("build", later, "--map", base, "-o", tmp_path / "alias.aion", "--tz", alias)
        assert members(tmp_path / "alias.aion") == members(tmp_path / "plain.aion")
        assert run_json("info", tmp_path / "alias.aion", "--format", "json")["timezone"] == zone
    ok("build", later, "--map", tmp_path / "Etc_UTC.aion", "-o", tmp_path / "c.aion",
       "--config", etc)
