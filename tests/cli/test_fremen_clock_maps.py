"""FreMEn's clock through the command line: a daily 08:00 rush (Europe/Berlin wall clock) learnt
by FreMEn alone peaks at 08:00 after the spring change; a map written before the clock existed
(its stored config without ``fremen_clock``) keeps UTC phases; it merges with a map on the new
clock, and moves to that clock when continued, while its time holds no summer time; a map whose
time held summer time keeps UTC when continued and is refused by such a merge."""

from __future__ import annotations

import json
import zipfile
from datetime import datetime, timedelta
from pathlib import Path
from zoneinfo import ZoneInfo

from aion_cli.engine.config import ModelConfig
from tests.cli.conftest import run

ZONE = ZoneInfo("Europe/Berlin")
CONFIG = ModelConfig(timezone="Europe/Berlin", families=("fremen",))


def _log(tmp: Path, name: str, first: datetime, days: int) -> Path:
    """A corridor walked by 20 people starting 08:00..08:57 Berlin time every day."""
    rows = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    tid = 0
    for d in range(days):
        day = first + timedelta(days=d)
        for minute in range(0, 60, 3):
            t0 = int(day.replace(hour=8, minute=minute, tzinfo=ZONE).timestamp())
            tid += 1
            rows += [f"{(t0 + s) * 10**9},{tid},{float(s)},0.0,0.0,0.0,1.0" for s in range(10)]
    csv = tmp / f"{name}.csv"
    csv.write_text("\n".join(rows) + "\n")
    end = first + timedelta(days=days)
    span = f"{first:%Y-%m-%d} 00:00..{end:%Y-%m-%d} 00:00"
    out = tmp / f"{name}.mcap"
    result = run("convert", csv, "-o", out, "--observed", span, "--tz", "Europe/Berlin", "-q")
    assert result.exit_code == 0, result.output
    return out


def _peak_hour(map_path: Path, day: str) -> int:
    result = run("predict", map_path, "--from", f"{day} 05:30", "--to", f"{day} 11:30",
                 "--step", "1h", "--top", "1", "--format", "csv")
    assert result.exit_code == 0, result.output
    rows = [line.split(",") for line in result.output.splitlines() if line.startswith("20")]
    best = max(rows, key=lambda r: float(r[9]))
    return int(best[0][11:13])


def _as_before_the_clock(path: Path, out: Path) -> None:
    """The map as a version before ``fremen_clock`` wrote it: the key absent from its
    stored configs (the arrays of a winter-only log are the same on either clock)."""
    with zipfile.ZipFile(path) as zin, zipfile.ZipFile(out, "w") as zout:
        for info in zin.infolist():
            data = zin.read(info)
            if info.filename == "manifest.json":
                manifest = json.loads(data)
                del manifest["config"]["fremen_clock"], manifest["state"]["config"]["fremen_clock"]
                data = json.dumps(manifest).encode()
            zout.writestr(info, data)


def _clock(path: Path) -> str | None:
    with zipfile.ZipFile(path) as z:
        manifest = json.loads(z.read("manifest.json"))
    clock: str | None = manifest["state"]["config"].get("fremen_clock")
    return clock


def test_fremen_rush_keeps_its_hour_and_an_older_map_keeps_its_clock(tmp_path: Path) -> None:
    march = _log(tmp_path, "march", datetime(2026, 3, 1), 28)  # before the 29 March change
    config = tmp_path / "fremen.toml"
    config.write_text(CONFIG.to_toml())
    new = tmp_path / "new.aion"
    result = run("build", march, "-o", new, "--config", config, "--derive-graph", "-q")
    assert result.exit_code == 0, result.output
    assert _clock(new) == "standard"
    assert _peak_hour(new, "2026-03-16") == 8
    assert _peak_hour(new, "2026-04-06") == 8  # on UTC phases: 9

    old = tmp_path / "old.aion"
    _as_before_the_clock(new, old)
    assert _peak_hour(old, "2026-03-16") == 8
    assert _peak_hour(old, "2026-04-06") == 9  # as it always forecast

    april = _log(tmp_path, "april", datetime(2026, 4, 1), 3)
    newer = tmp_path / "newer.aion"
    result = run("build", april, "-o", newer, "--config", config, "--derive-graph", "-q")
    assert result.exit_code == 0, result.output
    # winter days only: the older map's sums are the same on either clock, so they merge
    merged = tmp_path / "merged.aion"
    result = run("merge", old, newer, "-o", merged, "-q")
    assert result.exit_code == 0, result.output
    assert _clock(merged) == "standard"
    assert _peak_hour(merged, "2026-04-13") == 8

    # continued, a winter-only older map moves to the local clock (exactly: its sums are the
    # same on either), so the April days it learns keep their 08:00
    continued = tmp_path / "continued.aion"
    result = run("build", april, "--map", old, "-o", continued, "--config", config)
    assert result.exit_code == 0, result.output
    assert "goes on with FreMEn on the local clock" in " ".join(result.output.split())
    assert _clock(continued) == "standard"
    assert _peak_hour(continued, "2026-04-13") == 8


def test_an_older_map_that_held_summer_time_keeps_its_clock(tmp_path: Path) -> None:
    """An older map whose own days held summer time stays on UTC when continued (its sums
    are UTC's), and is refused by a merge with a map on the local clock."""
    config = tmp_path / "fremen.toml"
    config.write_text(CONFIG.to_toml())
    april = _log(tmp_path, "april", datetime(2026, 4, 1), 14)
    new = tmp_path / "new.aion"
    result = run("build", april, "-o", new, "--config", config, "--derive-graph", "-q")
    assert result.exit_code == 0, result.output
    old = tmp_path / "old.aion"
    _as_before_the_clock(new, old)
    may = _log(tmp_path, "may", datetime(2026, 5, 1), 3)
    result = run("build", may, "--map", old, "--config", config)
    assert result.exit_code == 0, result.output
    assert "local clock" not in result.output
    assert _clock(old) == "utc"  # continued: its sums stay on UTC

    newer = tmp_path / "newer.aion"
    result = run("build", _log(tmp_path, "june", datetime(2026, 6, 1), 3), "-o", newer,
                 "--config", config, "--derive-graph", "-q")
    assert result.exit_code == 0, result.output
    result = run("merge", old, newer, "-o", tmp_path / "merged2.aion")
    assert result.exit_code == 2
    assert "cannot merge old.aion with the other maps: its FreMEn phases" in result.output
    assert "Traceback" not in result.output
