"""The ATC protocols end to end on a small slice of the real data."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from aion_cli.evaluation.atc import atc_files, local_hour, run_atc
from aion_cli.evaluation.heading import UNIFORM_NLL
from tests.shared_data import SHARED_DATA

ATC = SHARED_DATA / "atc"
needs_atc = pytest.mark.skipif(
    not (ATC / "atc-1024-15_train.csv").is_file(),
    reason="the ATC data (../shared/data/atc) is not here",
)


def slice_of_atc(tmp_path: Path, hours: list[int], step: int) -> Path:
    """Every ``step``-th row of the real files (whole hours, fewer rows)."""
    for hour in hours:
        for split in ("train", "test"):
            src = ATC / f"atc-1024-{hour}_{split}.csv"
            if src.exists():
                lines = src.read_text().splitlines()[::step]
                (tmp_path / src.name).write_text("\n".join(lines) + "\n")
    return tmp_path


@needs_atc
def test_atc_files_are_indexed_by_hour_and_split() -> None:
    files = atc_files(ATC)
    assert (9, "train") in files
    assert (20, "test") in files
    assert (12, "train") not in files
    assert (12, "test") in files


@needs_atc
@pytest.mark.parametrize("protocol", ["random", "chronological"])
def test_protocol_runs_and_learned_models_beat_uniform(tmp_path: Path, protocol: str) -> None:
    data = slice_of_atc(tmp_path, [15, 16, 17], step=4)
    result = run_atc(data, protocol)
    hours = {r["hour"] for r in result.rows}
    assert hours == ({15, 16, 17} if protocol == "random" else {17})
    summary = {s["model"]: s for s in result.summary()}
    assert set(summary) == {
        "aion", "aion+graph", "aion static", "aion historical", "grid", "time-of-day histogram"
    }
    for name in ("aion", "aion static", "grid"):
        assert math.isfinite(summary[name]["nll_all"])
        assert summary[name]["nll_all"] < UNIFORM_NLL
    assert result.sizes["grid"] > 0
    assert result.sizes["aion"] > 0
    as_dict = result.to_dict()
    assert as_dict["association_radius_m"] == 1.0


def test_local_hour_is_japan_time() -> None:
    import numpy as np

    # 1351038020 s = 2012-10-24 00:20:20 UTC = 09:20 JST
    assert local_hour(np.array([1351038020 * 10**9]))[0] == 9
