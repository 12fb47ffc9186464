"""``aion simulate``'s closing lines name each scene's ground truth where it was written: they
said only its file name (``truth scene_00.truth.npz``), beside the log's full path
(``wrote runs/scene_00``), so the truth of ``-o runs/ --scenes 2`` (in ``runs/``) or of ``-o
/data/x.mcap`` read as a file in the working folder, where there was none."""

from __future__ import annotations

import re
from pathlib import Path

from tests.cli.conftest import run


def test_each_truth_is_named_where_it_is(tmp_path: Path) -> None:
    result = run("simulate", "-o", f"{tmp_path / 'runs'}/", "--days", "0.001", "--scenes", "2",
                 "--agents", "1")  # fmt: skip
    assert result.exit_code == 0, result.stderr
    said = re.findall(r"; truth (\S+)$", result.stderr, flags=re.MULTILINE)
    assert said == [str(tmp_path / "runs" / f"scene_0{k}.mcap.truth.npz") for k in (0, 1)]
    assert all(Path(p).is_file() for p in said)
