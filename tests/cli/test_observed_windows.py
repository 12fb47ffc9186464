"""A fixed sensor is observed only in the windows its logs recorded anything in: the time
between two recordings — inside one log or between two — never becomes observed zeros."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.types import DetectionBatch
from aion_cli.formats.tracks_log import tracks_to_log
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map

S = 1_000_000_000
HOUR = 3600 * S
DAY = 24 * HOUR
T0 = 1_762_070_400 * S  # Sunday 2025-11-02 08:00 UTC... aligned to 10-minute windows


def _people(start: int, n: int = 60) -> DetectionBatch:
    t = start + np.arange(n) * (HOUR // n)
    xy = np.column_stack([np.linspace(0.0, 3.0, n), np.zeros(n), np.zeros(n)])
    return DetectionBatch.from_arrays(t, xy, np.zeros(n), np.ones(n), np.arange(n) % 3)


def _windows_observed(path: Path) -> np.ndarray:
    """Windows observed per entry as queries see them (the log's last, still open window
    included: it has detections)."""
    state = load_map(path).state
    rows = state.entries.live_rows()
    out: np.ndarray = state.query_temporal().windows_observed(rows)
    return out


def test_two_recordings_in_one_log_leave_the_days_between_unobserved(tmp_path: Path) -> None:
    first, second = T0, T0 + 3 * DAY  # one hour each, three days apart
    batch = DetectionBatch.concat([_people(first), _people(second)])
    log = tmp_path / "two_sessions.mcap"
    tracks_to_log(batch, log, observed=[(first, first + HOUR), (second, second + HOUR)])
    report = build_map(BuildOptions(logs=(log,), output=tmp_path / "m.aion"))
    assert report.observation.startswith("fixed sensor over the 12 windows")
    windows = _windows_observed(report.output)
    np.testing.assert_array_equal(windows, 12.0)  # 6 + 6 ten-minute windows, never the gap


def test_two_logs_observe_their_own_windows_only(tmp_path: Path) -> None:
    logs = []
    for k, start in enumerate((T0, T0 + 2 * DAY)):
        log = tmp_path / f"day{k}.mcap"
        tracks_to_log(_people(start), log, observed=[(start, start + HOUR)])
        logs.append(log)
    together = build_map(BuildOptions(logs=tuple(logs), output=tmp_path / "ab.aion"))
    first = build_map(BuildOptions(logs=(logs[0],), output=tmp_path / "a.aion"))
    continued = build_map(
        BuildOptions(logs=(logs[1],), output=tmp_path / "a.aion", continue_from=first.output)
    )
    np.testing.assert_array_equal(_windows_observed(together.output), 12.0)
    np.testing.assert_array_equal(_windows_observed(continued.output), 12.0)


def test_declared_spans_make_empty_windows_observed_zeros(tmp_path: Path) -> None:
    """An hour of people inside a declared five-hour recording: the other four hours are real
    zeros, so the rate per window is a fifth of the busy hour's."""
    log = tmp_path / "long.mcap"
    tracks_to_log(_people(T0), log, observed=[(T0, T0 + 5 * HOUR)])
    report = build_map(BuildOptions(logs=(log,), output=tmp_path / "m.aion"))
    windows = _windows_observed(report.output)
    np.testing.assert_array_equal(windows, 30.0)
    from aion_cli.engine.query import historical_table

    flow = historical_table(load_map(report.output).state).flow
    assert float(np.nansum(flow)) == pytest.approx(60 / 30)
