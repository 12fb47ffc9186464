"""The terminal tables read as what they hold: a small non-zero rate keeps two significant
digits (``cli.output.small_num``: the predict table's flows, info's topic rates), so 0.00
means none; a map of months of daily logs lists its first and last inputs, not every one."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import run, run_json


@pytest.mark.parametrize(
    ("value", "shown"),
    [(0.0, "0.00"), (0.0031, "0.0031"), (0.1, "0.10"), (2.5, "2.50"), (1.2e-5, "1.2e-05"),
     (None, "-"), (float("nan"), "-")],
)
def test_a_small_flow_reads_as_something(value: float | None, shown: str) -> None:
    """The predict table's flow column: a quiet place's 0.0031 detections per window read
    0.00 beside the empty ones; below 0.1 it keeps two significant digits (as info's rates),
    so 0.00 means none."""
    from aion_cli.cli.entries import COLUMNS

    flow = next(c for c in COLUMNS if c.key == "flow")
    assert flow.fmt(value) == shown


def test_the_predict_table_shows_small_flows(sample_map: Path) -> None:
    """Every flow the JSON gives between 0 and 0.005 shows non-zero in the table."""
    at = "2026-01-06 03:00"
    entries = run_json("predict", sample_map, "--time", at, "--format", "json")["entries"]
    table = run("predict", sample_map, "--time", at, "--format", "table").stdout
    small = [e for e in entries if e["flow"] is not None and 0 < e["flow"] < 0.005]
    assert small  # the sample's office at night has quiet places
    for entry in small:
        row = next(line for line in table.splitlines() if f" {entry['id']} " in line)
        assert "0.00 " not in row.split("│")[6]


def test_a_long_deployment_lists_its_first_and_last_logs() -> None:
    """A map continued day after day for 70 days listed 70 input rows in ``aion info``; past
    eight it lists the first and last four and counts the 62 between (JSON keeps all)."""
    from aion_cli.cli.info_map import input_rows

    logs = [{"name": f"day{k:02d}.mcap", "size": 2048, "sha256": f"{k:064x}"}
            for k in range(70)]
    rows = input_rows(logs)
    assert len(rows) == 9
    assert [r.split()[0] for r in rows[:4]] == ["day00.mcap", "day01.mcap", "day02.mcap",
                                                "day03.mcap"]
    assert rows[4] == "... 62 more logs (of 70; --format json lists every one)"
    assert [r.split()[0] for r in rows[5:]] == ["day66.mcap", "day67.mcap", "day68.mcap",
                                                "day69.mcap"]
    assert rows[0] == "day00.mcap  2.0 KiB  sha256 000000000000"
    assert len(input_rows(logs[:8])) == 8  # up to eight: every one


def test_the_series_table_shows_small_flows(sample_map: Path) -> None:
    """``predict --from --to``'s table wrote every flow with two decimals, so the night's
    0.0031 read 0.00, as an empty place does; it now reads as the predict table does: every
    flow the JSON gives between 0 and 0.005 shows as itself to two significant digits."""
    night = run_json("predict", sample_map, "--time", "2026-01-06 03:00", "--format", "json")
    quiet = [e["id"] for e in night["entries"] if e["flow"] is not None and 0 < e["flow"] < 0.005]
    span = ("--from", "2026-01-06 02:00", "--to", "2026-01-06 04:00")
    span += tuple(arg for node in quiet[:4] for arg in ("--node", node))
    doc = run_json("predict", sample_map, *span, "--format", "json")
    table = run("predict", sample_map, *span, "-q").stdout
    rows = [line.split("│")[1:-1] for line in table.splitlines() if line.startswith("│")]
    assert len(rows) == len(doc["times"])
    checked = 0
    for j, row in enumerate(rows):
        for k, entry in enumerate(doc["entries"]):
            value, cell = entry["flow"][j], row[k + 1].strip()
            if value is not None and 0 < value < 0.005:
                assert cell != "0.00"
                assert float(cell) == pytest.approx(value, rel=0.05)
                checked += 1
    assert checked  # the sample's office at night has quiet places
