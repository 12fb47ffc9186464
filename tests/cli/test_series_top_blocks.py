"""A series orders its entries by means reduced a block of rows at a time
(:func:`aion_cli.prediction_series._means`): the same entries, values and order whatever the
block, and ``--top N`` (the table's eight) is the whole series cut afterwards; the old
whole-array ``np.nanmean`` is the reference."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import aion_cli as aion
from aion_cli import prediction_series
from tests.cli.conftest import run

T0, T1 = "2026-01-12 05:00", "2026-01-13 21:00"


@pytest.mark.parametrize("block", [1, 7, 50, 1 << 22])
@pytest.mark.parametrize("top", [1, 8, 40])
def test_top_equals_whole_series_cut(
    sample_map: Path, monkeypatch: pytest.MonkeyPatch, block: int, top: int
) -> None:
    m = aion.Map.load(sample_map)
    whole = m.predict_series(T0, T1, "1h", tz="UTC")
    monkeypatch.setattr(prediction_series, "BLOCK_VALUES", block)
    cut = m.predict_series(T0, T1, "1h", tz="UTC", top=top)
    assert whole.flow.shape[0] > 40
    assert cut.entries == whole.entries[:top]
    assert cut.matched == whole.matched
    flow = whole.flow  # the old reduction over the whole array orders the same way
    known = np.isfinite(flow).any(axis=1)
    mean = np.zeros(flow.shape[0])
    mean[known] = np.nanmean(flow[known], axis=1)
    assert (np.diff(np.where(known, mean, -np.inf)) <= 0).all()
    if block == 1:  # row by row
        k2, m2 = prediction_series._means(flow)
        np.testing.assert_array_equal(k2, known)
        np.testing.assert_array_equal(m2, mean)
    np.testing.assert_array_equal(cut.flow, whole.flow[:top])
    np.testing.assert_array_equal(cut.flow_per_hour, whole.flow_per_hour[:top])


def test_table_shows_the_busiest_of_the_whole_series(sample_map: Path) -> None:
    """The table keeps only its eight columns: the same as the JSON's first eight."""
    m = aion.Map.load(sample_map)
    whole = m.predict_series(T0, T1, "1h", tz="UTC")
    result = run("predict", sample_map, "--from", T0, "--to", T1, "--step", "1h", "--tz", "UTC")
    assert result.exit_code == 0, result.stderr
    header = next(line for line in result.stdout.splitlines() if "time" in line)
    shown = [w for w in header.replace("┃", " ").replace("│", " ").split() if w != "time"]
    assert shown == [e["id"] for e in whole.entries[:8]]
    assert "showing the 8 busiest" in result.stderr
