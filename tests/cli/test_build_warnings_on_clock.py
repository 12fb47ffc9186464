"""``aion build`` shows the times of its warnings and notes on the map's clock, as ``aion
info`` shows them on the clock the build will follow; JSON keeps them in UTC.

Before (stop 67's audit): a THÖR run converted twice (an MCAP and a bag) with ``--tz
Europe/Stockholm`` built into a map of Stockholm's hours, and the build warned that both logs
hold the same people "from 2026-01-05 09:00:00 UTC to ...", where ``aion info`` of the same
logs said "from 2026-01-05 10:00:00+01:00" and the map's hours read 10:00-11:00."""

from __future__ import annotations

import json
from pathlib import Path

from tests.cli.conftest import run

START_S = 1767603600  # 2026-01-05 09:00:00 UTC = 10:00:00 in Stockholm (UTC+1 in winter)


def _copies(tmp_path: Path) -> tuple[Path, Path]:
    rows = [f"{k * 0.4:.2f},1,{k * 0.5:.1f},0.0,1.25,0.0" for k in range(400)]
    src = tmp_path / "thor.csv"
    src.write_text("\n".join(rows) + "\n")
    logs = tmp_path / "run.mcap", tmp_path / "run.bag"  # one run in two containers
    for log in logs:
        made = run("convert", src, "--layout", "thor", "--start", "2026-01-05 10:00", "--tz",
                   "Europe/Stockholm", "-o", log, "-q")  # fmt: skip
        assert made.exit_code == 0, made.stderr
    return logs


def _twice(text: str) -> list[str]:
    return [w for w in " ".join(text.split()).split("warning: ")[1:] if "both hold" in w]


def test_a_builds_warnings_are_on_the_maps_clock(tmp_path: Path) -> None:
    first, again = _copies(tmp_path)
    info = run("info", first, again)
    assert info.exit_code == 0, info.stderr
    (said_by_info,) = _twice(info.stderr)
    assert "from 2026-01-05 10:00:00+01:00 to" in said_by_info  # info's clock, as before
    built = run("build", first, again, "--derive-graph", "-o", tmp_path / "a.aion")
    assert built.exit_code == 0, built.stderr
    assert "weekdays 10:00-11:00; weekends none" in " ".join(built.stderr.split())
    (said,) = _twice(built.stderr)
    assert "from 2026-01-05 10:00:00+01:00 to 2026-01-05 10:02:39+01:00" in said
    assert "UTC" not in said
    # --format json: stdout keeps UTC, the warnings on stderr are on the map's clock
    as_json = run("build", first, again, "--derive-graph", "-o", tmp_path / "b.aion",
                  "--format", "json")  # fmt: skip
    assert as_json.exit_code == 0, as_json.stderr
    (kept,) = [w for w in json.loads(as_json.stdout)["warnings"] if "both hold" in w]
    assert "from 2026-01-05 09:00:00 UTC to 2026-01-05 09:02:39 UTC" in kept
    (shown,) = _twice(as_json.stderr)
    assert "from 2026-01-05 10:00:00+01:00" in shown


def test_a_utc_maps_warnings_keep_utc(tmp_path: Path) -> None:
    first, again = _copies(tmp_path)
    built = run("build", first, again, "--derive-graph", "--tz", "UTC", "-o", tmp_path / "u.aion")
    assert built.exit_code == 0, built.stderr
    (said,) = _twice(built.stderr)
    assert "from 2026-01-05 09:00:00 UTC to 2026-01-05 09:02:39 UTC" in said


def test_a_merges_first_and_last_time_are_on_the_maps_clock(tmp_path: Path) -> None:
    """aion merge's table gave the merged map's first and last time in UTC beside its hours
    observed on the map's clock; now both on the map's clock, with its offset."""
    rows = [f"{k * 0.4:.2f},1,{k * 0.5:.1f},0.0,1.25,0.0" for k in range(400)]
    src = tmp_path / "thor.csv"
    src.write_text("\n".join(rows) + "\n")
    maps = []
    for day in ("2026-01-05", "2026-01-07"):
        log, site = tmp_path / f"{day}.mcap", tmp_path / f"{day}.aion"
        made = run("convert", src, "--layout", "thor", "--start", f"{day} 10:00", "--tz",
                   "Europe/Stockholm", "-o", log, "-q")  # fmt: skip
        assert made.exit_code == 0, made.stderr
        built = run("build", log, "--derive-graph", "-o", site, "-q")
        assert built.exit_code == 0, built.stderr
        maps.append(site)
    merged = run("merge", *maps, "-o", tmp_path / "both.aion")
    assert merged.exit_code == 0, merged.stderr
    said = " ".join(merged.stderr.split())
    assert "first time │ 2026-01-05 10:00:00+01:00" in said
    assert "last time │ 2026-01-07 10:02:39+01:00" in said
