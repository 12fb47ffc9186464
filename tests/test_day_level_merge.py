"""The days' level sums (``temporal_day_level``, engine/temporal/day_level.py) add exactly:
part maps merged equal one build of their logs, and a map continued with ``build --map`` equals
one build, member for member (logs of ``tests/cli/logdata.py``, two hours each on different
days)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.formats.mapfile import read_map
from tests.cli.conftest import run
from tests.test_part_maps import _each_built, _logs


def _level(path: Path) -> np.ndarray:
    arrays, _manifest = read_map(path)
    out: np.ndarray = arrays["temporal_day_level"]
    return out


def test_merged_parts_and_continued_maps_hold_one_builds_day_level(tmp_path: Path) -> None:
    logs = _logs(tmp_path, [0, 1, 2, 4])  # closed days 0, 1, 2; day 4 pending
    whole = tmp_path / "whole.aion"
    assert run("build", *logs, "-o", whole, "--workers", "1", "-q").exit_code == 0
    level = _level(whole)
    assert level[0].max() == 3  # three closed days seen in a cell: sums of three days
    assert level[1].sum() > 0
    parts = _each_built(tmp_path, logs, "part", "--part")
    merged = tmp_path / "merged.aion"
    assert run("merge", *parts, "-o", merged, "-q").exit_code == 0
    np.testing.assert_array_equal(_level(merged), level)
    continued = tmp_path / "continued.aion"
    assert run("build", *logs[:2], "-o", continued, "-q").exit_code == 0
    assert run("build", *logs[2:], "--map", continued, "-q").exit_code == 0
    np.testing.assert_array_equal(_level(continued), level)
