"""``aion simulate --tz ZONE`` writes the zone into its MCAP log; ``aion build`` without
``--tz`` follows it (a note says so) and warns when ``--tz`` names another: a London scene
built in UTC had its summer hours an hour off, without a word."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.log_zone import declared_zones
from aion_cli.formats.mapfile import read_manifest
from aion_cli.formats.writers import LogWriter
from tests.cli.conftest import run, run_json


@pytest.fixture(scope="module")
def london(tmp_path_factory: pytest.TempPathFactory) -> Path:
    log = tmp_path_factory.mktemp("zone") / "lon.mcap"
    out = run("simulate", "-o", log, "--days", "1", "--robot", "fixed", "--agents", "3",
              "--tz", "Europe/London", "--start", "2026-06-01")
    assert out.exit_code == 0, out.output
    return log


def test_a_build_without_tz_follows_the_zone_the_log_declares(
    london: Path, tmp_path: Path
) -> None:
    assert declared_zones([london]) == {str(london): "Europe/London"}
    out = tmp_path / "a.aion"
    built = run_json("build", london, "-o", out, "--format", "json")
    assert read_manifest(out)["timezone"] == "Europe/London"
    assert any("lon.mcap declares the time zone Europe/London" in n for n in built["notes"])
    assert not built["warnings"]


def test_another_tz_is_kept_with_a_warning(london: Path, tmp_path: Path) -> None:
    out = tmp_path / "b.aion"
    built = run_json("build", london, "-o", out, "--tz", "UTC", "--format", "json")
    assert read_manifest(out)["timezone"] == "UTC"
    (warning,) = [w for w in built["warnings"] if "declares the time zone" in w]
    assert "Europe/London" in warning
    assert "--tz UTC" in warning
    same = run_json("build", london, "-o", tmp_path / "c.aion", "--tz", "Europe/London",
                    "--format", "json")
    assert not [w for w in same["warnings"] if "declares the time zone" in w]


def test_only_mcap_files_carry_the_record(tmp_path: Path) -> None:
    with LogWriter(tmp_path / "a.mcap") as log:
        assert log.add_metadata("aion", {"timezone": "Asia/Tokyo"})
    with LogWriter(tmp_path / "a.bag", "bag") as log:
        assert not log.add_metadata("aion", {"timezone": "Asia/Tokyo"})
    found = declared_zones([tmp_path / "a.mcap", tmp_path / "a.bag"])
    assert found == {str(tmp_path / "a.mcap"): "Asia/Tokyo"}


def test_the_python_api_follows_the_declared_zone_too(london: Path, tmp_path: Path) -> None:
    import warnings

    import aion_cli as aion

    built = aion.build(london, tmp_path / "api.aion")
    assert built.timezone == "Europe/London"
    assert any("declares the time zone Europe/London" in n for n in built.report.notes)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        other = aion.build(london, tmp_path / "utc.aion", tz="UTC")
    assert other.timezone == "UTC"
    assert any("declares the time zone Europe/London" in str(w.message) for w in caught)
