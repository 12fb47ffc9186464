"""The windows a map observed (``mapquery.state_counts``: the most any entry saw, each window
for the share of it recorded) are shown whole, a half rounded up: a fixed sensor recording
from 08:05 to 08:50 watched 4.5 windows of 10 minutes, which Python's ``round`` showed as 4
(halves go to the even number) in the build summary, ``aion info`` and the report."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import run, run_json


def _watched_map(path: Path, start: str, end: str) -> Path:
    """A map of one fixed sensor recording from ``start`` to ``end`` (one detection)."""
    from aion_cli.api import Map
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch
    from aion_cli.timeparse import parse_time, resolve_zone

    utc = resolve_zone("UTC")
    t0, t1 = parse_time(start, utc), parse_time(end, utc)
    config = ModelConfig()
    assert config.window_s == 600.0  # the windows counted below are 10 minutes long
    mapper = Mapper(config)
    mapper.set_fixed_sensor(t0, t1)
    xyz = np.array([[0.2, 0.2, 0.0]])
    mapper.add_detections(DetectionBatch.from_arrays(np.array([t0 + 10**9]), xyz, np.zeros(1)))
    mapper.advance(t1)
    Map.from_state(mapper.state, timezone="UTC").save(path)
    return path


@pytest.mark.parametrize(
    ("start", "end", "shown"),
    [
        ("2026-11-23 08:05", "2026-11-23 08:50", 5),  # 0.5 + 1 + 1 + 1 + 1 = 4.5 windows
        ("2026-11-23 08:05", "2026-11-23 08:30", 3),  # 0.5 + 1 + 1 = 2.5
        ("2026-11-23 08:05", "2026-11-23 08:42", 4),  # 0.5 + 1 + 1 + 1 + 0.2 = 3.7
        ("2026-11-23 08:00", "2026-11-23 08:04", 1),  # 0.4: never 0 beside its detection
    ],
)
def test_half_a_window_rounds_up(tmp_path: Path, start: str, end: str, shown: int) -> None:
    watched = _watched_map(tmp_path / "w.aion", start, end)
    assert run_json("info", watched, "--format", "json")["counts"]["windows"] == shown
    table = run("info", watched)
    assert table.exit_code == 0, table.stderr
    row = next(line for line in table.stdout.splitlines() if "windows observed" in line)
    assert row.split("│")[2].strip() == str(shown)


def test_half_up() -> None:
    from aion_cli.number_text import half_up

    assert [half_up(v) for v in (0.5, 1.5, 2.5, 4.5, 4.49, -0.5, 3.0)] == [1, 2, 3, 5, 4, 0, 3]


@pytest.mark.parametrize(
    ("value", "text"),
    [(0.974, "0.974"), (46.84, "46.8"), (10.0, "10"), (1567.7, "1,570"), (999.7, "1,000"),
     (331_000.4, "331,000"), (0.0012345, "0.00123"), (0.0, "0"), (-2.5, "-2.5")],
)
def test_three_significant_digits_without_an_exponent(value: float, text: str) -> None:
    """The pictures' legends give flows to three significant digits: ``:.3g`` wrote 1,570
    as ``1.57e+03``."""
    from aion_cli.number_text import significant

    assert significant(value) == text
