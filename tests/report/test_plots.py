"""The report's pictures, read back from their matplotlib artists: axis labels name the
zone the times are shown in."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.report import plots
from aion_cli.report.content import Series
from aion_cli.timeparse import resolve_zone

NS = 1_000_000_000
MONDAY_TOKYO = 1350831600 * NS  # Mon 2012-10-22 00:00 Asia/Tokyo


@pytest.fixture
def drawn(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The figures the report's pictures are saved from."""
    figures: list[Any] = []
    save = plots._save

    def keep(fig: Any, path: Path) -> Path:
        figures.append(fig)
        return save(fig, path)

    monkeypatch.setattr(plots, "_save", keep)
    return figures


@pytest.mark.parametrize("hours", [24, 7 * 24])
def test_the_time_axis_names_its_zone(tmp_path: Path, drawn: list[Any], hours: int) -> None:
    """A day's and a week's curves are drawn by the clock of the report's zone; the week's
    axis had no label at all, so nothing said in which zone its days start."""
    times = MONDAY_TOKYO + np.arange(hours) * 3600 * NS
    series = Series("t", times, ("whole map",), np.ones((hours, 1)))
    plots.activity_png(series, "detections per 10 min", tmp_path / "a.png",
                       resolve_zone("Asia/Tokyo"))
    (ax,) = drawn[-1].axes
    assert "Asia/Tokyo" in ax.get_xlabel()
    if hours > 24:  # the days start at the zone's midnight
        assert ax.get_xticklabels()[0].get_text() == "Mon 22"

