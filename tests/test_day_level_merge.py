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


def test_a_map_written_before_the_member_is_read_and_continued(tmp_path: Path) -> None:
    """A 2.0 map (no ``temporal_day_level``, as aion wrote it before) forecasts as a map
    with no days' level and continues into a 2.1 map whose sums hold the days closed
    since; the sums of the map's own days are not invented."""
    import json
    import zipfile

    logs = _logs(tmp_path, [0, 1, 2, 4])
    new = tmp_path / "new.aion"
    assert run("build", *logs[:2], "-o", new, "-q").exit_code == 0
    old = tmp_path / "old.aion"
    with zipfile.ZipFile(new) as zin:
        contents = {n: zin.read(n) for n in zin.namelist() if n != "temporal_day_level.npy"}
    manifest = json.loads(contents["manifest.json"])
    assert manifest["version"] == "2.3"
    manifest["version"] = "2.0"
    del manifest["members"]["temporal_day_level"]
    contents["manifest.json"] = json.dumps(manifest).encode()
    with zipfile.ZipFile(old, "w", compression=zipfile.ZIP_STORED) as zout:
        for name, data in contents.items():
            zout.writestr(name, data)
    assert "temporal_day_level" not in read_map(old)[0]
    assert run("predict", old, "--layer", "rooms", "-q").exit_code == 0
    assert run("build", *logs[2:], "--map", old, "-q").exit_code == 0
    arrays, written = read_map(old)
    assert written["version"] == "2.3"
    # day 0 closed before (in the 2.0 map: no sums), days 1 and 2 closed since
    assert arrays["temporal_day_level"][0].max() == 2
