"""Issue 12's periodic targets measured from outside: a log written the way a robot records it
(a ROS 1 bag of id-less ``geometry_msgs/PoseArray`` from a tracker that publishes only when it
sees someone), built and queried through the command line in a zone whose clocks change
inside the data. The answers are known from how the log was made: people walk a 10 m
corridor at 1.25 m/s, sampled at 2 Hz (16 detections each), 12 an hour in the local rush
hours 08-10 and 17-19 on weekdays, nobody else."""

from __future__ import annotations

from datetime import datetime, timedelta
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.formats.writers import LogWriter
from tests.cli.conftest import run, run_json

S = 1_000_000_000
ZONE = "Europe/Berlin"
FIRST = "2026-03-09"  # a Monday; the clocks go forward on Sunday 2026-03-29
DAYS = 21
AFTER = "2026-03-30"  # the Monday after the data
RATE = 12  # people an hour in the rush
SAMPLES = 16  # detections per walk: 8 s at 2 Hz
RUSH_FLOW = RATE * SAMPLES / 6  # detections per 10-minute window in a rush hour
TOPIC = "/people_tracker/pose_array"


def _walks(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Every detection's time (ns, sorted) and x along the corridor."""
    zone = ZoneInfo(ZONE)
    starts = []
    for d in range(DAYS):
        day = datetime.fromisoformat(FIRST) + timedelta(days=d)
        if day.weekday() >= 5:
            continue
        for hour in (8, 9, 17, 18):
            t_hour = int(day.replace(hour=hour, tzinfo=zone).timestamp()) * S
            n = int(rng.poisson(RATE))
            starts.append(t_hour + np.sort(rng.integers(0, 3600 * S - 10 * S, n)) // S * S)
    t0 = np.concatenate(starts)
    k = np.arange(SAMPLES)
    t = (t0[:, None] + k[None, :] * (S // 2)).reshape(-1)
    east = rng.random(t0.size) < 0.7
    x = np.where(east[:, None], 0.3 + 0.625 * k[None, :], 9.7 - 0.625 * k[None, :]).reshape(-1)
    return t, x


@pytest.fixture(scope="module")
def corridor(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The bag: one PoseArray per 2 Hz tick with somebody in the corridor, none otherwise."""
    log = tmp_path_factory.mktemp("periodic") / "corridor.bag"
    t, x = _walks(np.random.default_rng(12))
    ticks, first = np.unique(t, return_index=True)
    bounds = np.append(first, t.size)
    y = np.random.default_rng(13).uniform(0.5, 1.5, t.size)
    with LogWriter(log, "bag") as writer:
        for i, tick in enumerate(ticks.tolist()):
            rows = range(bounds[i], bounds[i + 1])
            writer.write(TOPIC, "geometry_msgs/msg/PoseArray", {
                "header": {"stamp": {"sec": tick // S, "nanosec": tick % S}, "frame_id": "map"},
                "poses": [{"position": {"x": float(x[j]), "y": float(y[j]), "z": 0.0},
                           "orientation": {"w": 1.0}} for j in rows],
            }, tick)
    return log


def _build(log: Path, out: Path, *extra: str | Path) -> dict[str, Any]:
    report: dict[str, Any] = run_json(
        "build", log, "-o", out, "--tz", ZONE, "--workers", "1", "--format", "json", *extra
    )
    return report


def _flows(path: Path, when: str | None) -> dict[str, dict[str, Any]]:
    at = ("--time", when) if when else ("--historical",)
    entries = run_json("predict", path, *at, "--format", "json")["entries"]
    return {str(e["id"]): e for e in entries}


def _total(path: Path, when: str) -> float:
    return sum(float(e["flow"] or 0.0) for e in _flows(path, when).values())


OBSERVED = f"{FIRST} 00:00..{AFTER} 00:00"


def test_rush_night_and_weekend_of_a_silent_tracker_declared_observed(
    corridor: Path, tmp_path: Path
) -> None:
    """Declared observed, the silent hours are empty: 03:00 is at most 5 % of 09:00, which
    holds the rush's known rate (local time on both sides of the clock change), and the
    Saturday after three weeks of weekdays at most 10 % of the Monday."""
    out = tmp_path / "declared.aion"
    report = _build(corridor, out, "--observed", OBSERVED)
    assert str(report["observation"]).startswith("fixed sensor over the")
    assert report["headings"]["linked"] > 0  # id-less: linked tracks
    night = _total(out, f"{AFTER} 03:00")
    rush = _total(out, f"{AFTER} 09:00")
    assert rush == pytest.approx(RUSH_FLOW, rel=0.25)
    assert night <= 0.05 * rush
    saturday = _total(out, "2026-04-04 09:00")
    assert saturday <= 0.10 * rush
    # the rush kept its local hour across the change: 06:00 UTC is 08:00 summer time, the
    # rush, where it was 07:00 winter time, quiet, on the 15 weekdays before the change
    assert _total(out, f"{AFTER} 09:00") == _total(out, f"{AFTER} 07:00 UTC")
    assert _total(out, f"{AFTER} 06:00 UTC") >= 0.5 * RUSH_FLOW
    assert _total(out, f"{AFTER} 05:00 UTC") <= 0.05 * rush  # 07:00 summer time


def test_undeclared_silent_hours_forecast_the_static_rate_and_say_why(
    corridor: Path, tmp_path: Path
) -> None:
    """Without --observed the nights and weekends were never observed, and every window
    observed held the rush: every entry keeps its static rate, the rush's, at night and on a
    Saturday alike (README: an unobserved hour is extrapolated), and the notes say why and
    how to declare the silent spans."""
    out = tmp_path / "silent.aion"
    report = _build(corridor, out)
    assert any("aion build --observed" in n for n in report["notes"])
    night = run("predict", out, "--time", f"{AFTER} 03:00", "--format", "json")
    assert night.exit_code == 0
    text = " ".join(night.stderr.split())
    assert "no log observed 03:00-04:00 (Europe/Berlin) on any day" in text
    assert "declare the spans it was recording with aion build --observed" in text
    assert "every entry forecasts its static rate" in text
    # the rate of the windows with messages: the rush's, at night and on Saturday alike
    rate = sum(float(e["flow"]) for e in _flows(out, None).values())
    assert _total(out, f"{AFTER} 03:00") == pytest.approx(rate, rel=1e-12)
    assert _total(out, "2026-04-04 09:00") == pytest.approx(rate, rel=1e-12)
    assert rate == pytest.approx(RUSH_FLOW, rel=0.25)


@pytest.mark.parametrize("prior", [0.0, 10.0])
def test_static_only_predicts_the_historical_map(
    corridor: Path, tmp_path: Path, prior: float
) -> None:
    """Every temporal family off: the prediction's flows equal --historical entry by entry
    at night and in the rush, and so do its histograms with direction_prior = 0 (with the
    default prior they are pooled toward the neighbourhood's, and the note says so)."""
    config = tmp_path / "static.toml"
    config.write_text(ModelConfig(families=("static",), direction_prior=prior).to_toml())
    out = tmp_path / "static.aion"
    _build(corridor, out, "--observed", OBSERVED, "--config", config)
    historical = _flows(out, None)
    for when in (f"{AFTER} 03:00", f"{AFTER} 09:00"):
        predicted = _flows(out, when)
        assert predicted.keys() == historical.keys()
        for key, entry in predicted.items():
            past = historical[key]
            assert entry["family"] == "static"
            assert entry["flow"] == pytest.approx(past["flow"], abs=1e-9)
            if prior == 0.0:
                np.testing.assert_allclose(entry["histogram"], past["histogram"], atol=1e-9)
    note = " ".join(run("predict", out, "--time", f"{AFTER} 03:00").stderr.split())
    assert 'has the static family only (families = ["static"])' in note


@pytest.fixture(scope="module")
def daily_files(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """The same walks recorded one bag per local day, as a robot team keeps them: a file
    starts at the day's first detection and ends at its last (08:00 to 19:00 or so), so the
    nights and the weekends lie between the files."""
    folder = tmp_path_factory.mktemp("daily")
    t, x = _walks(np.random.default_rng(12))
    y = np.random.default_rng(13).uniform(0.5, 1.5, t.size)
    zone = ZoneInfo(ZONE)
    # _walks keeps each walk's samples together, walk after walk: a walk's day is its start's
    day_of = np.array([datetime.fromtimestamp(v // S, zone).date().toordinal()
                       for v in t[::SAMPLES].tolist()]).repeat(SAMPLES)
    logs = []
    for day in np.unique(day_of).tolist():
        rows = np.flatnonzero(day_of == day)
        ticks, first = np.unique(t[rows], return_index=True)
        bounds = np.append(first, rows.size)
        log = folder / f"{datetime.fromordinal(day).date()}.bag"
        with LogWriter(log, "bag") as writer:
            for i, tick in enumerate(ticks.tolist()):
                r = rows[bounds[i]: bounds[i + 1]]
                writer.write(TOPIC, "geometry_msgs/msg/PoseArray", {
                    "header": {"stamp": {"sec": tick // S, "nanosec": tick % S},
                               "frame_id": "map"},
                    "poses": [{"position": {"x": float(x[j]), "y": float(y[j]), "z": 0.0},
                               "orientation": {"w": 1.0}} for j in r.tolist()],
                }, tick)
        logs.append(log)
    return logs


def test_daily_files_of_a_silent_tracker_declared_observed(
    daily_files: list[Path], tmp_path: Path
) -> None:
    """One file per weekday, the nights and weekends between the files: declared observed,
    the time between the files counts as empty, as in one log, so the targets hold (it had
    stayed unknown: night 34.5 % of the rush), and no note says the declared nights stay
    unknown."""
    assert len(daily_files) == 15
    out = tmp_path / "daily.aion"
    report = _build(daily_files[0], out, *daily_files[1:], "--observed", OBSERVED)
    rush = _total(out, f"{AFTER} 09:00")
    assert rush == pytest.approx(RUSH_FLOW, rel=0.25)
    assert _total(out, f"{AFTER} 03:00") <= 0.05 * rush
    assert _total(out, "2026-04-04 09:00") <= 0.10 * rush
    # no declared hour stays unknown: those before the first file (Monday 00:00-08:00) and
    # after the last (Friday evening on; they had stayed unknown) count, the map running from
    # the span's start to its end
    assert not [n for n in report["notes"] if "stay unknown" in n]
