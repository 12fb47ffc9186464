"""README quotes how many detections of ATC's hour 9 test split ``aion build`` links into
tracks once ``aion convert --drop-ids`` has taken their ids away; the figure is the build's."""

from __future__ import annotations

import re
from pathlib import Path

from tests.cli.conftest import run, run_json
from tests.shared_data import REPO, real


def test_the_readme_quotes_the_linked_count_the_build_reports(tmp_path: Path) -> None:
    """Before: README said 2,250 of 2,504 detections linked while the build linked 2,392."""
    log = tmp_path / "atc.mcap"
    made = run("convert", real("atc", "atc-1024-9_test.csv"), "--layout", "atc",
               "--drop-ids", "-o", log)  # fmt: skip
    assert made.exit_code == 0, made.stderr
    report = run_json("build", log, "-o", tmp_path / "atc.aion", "--format", "json")
    headings = report["headings"]
    total = sum(int(v) for v in headings.values())
    readme = " ".join((REPO / "README.md").read_text().split())
    quoted = re.search(r"ATC hour 9 test split: ([\d,]+) of ([\d,]+) detections linked", readme)
    assert quoted is not None
    assert int(quoted[2].replace(",", "")) == total == 2504  # the split's rows (README, data)
    assert int(quoted[1].replace(",", "")) == headings["linked"]
