"""A map's entry count said the same way by every command that prints one. A fixed-sensor map
of 162 places and 240 hash cells read "entries 365" in ``aion compact`` and ``aion report``,
while ``aion predict`` and ``entries.csv`` had 402 rows (37 places with family "none") and
``aion info`` gave no entry count at all. The count stays the entries (places and cells with
a model); info, compact and report now all add the places without data, in the same words.

The small office: 7 places, p5 and p6 beyond the sensor's range hold no entry, no hash cell:
5 entries (+2 places without data), and predict lists all 7."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import Office, run, run_json

SAID = "5 (+2 places without data)"


def _flat(text: str) -> str:
    return " ".join(text.split())


def test_info_compact_and_report_count_the_entries_alike(office: Office, tmp_path: Path) -> None:
    rows = run_json("predict", office.map, "--historical", "--format", "json")["entries"]
    assert len(rows) == 7
    assert sum(1 for r in rows if r["family"] == "none") == 2  # p5, p6: no entry

    small = tmp_path / "robot.aion"
    summary = run_json("compact", office.map, "-o", small, "--format", "json")
    assert (summary["entries"], summary["places_without_data"]) == (5, 2)
    compact = run("compact", office.map, "-o", tmp_path / "again.aion")
    assert compact.exit_code == 0, compact.stderr
    assert f"entries │ {SAID} │" in _flat(compact.stderr)

    for path in (office.map, small):
        doc = run_json("info", path, "--format", "json")
        assert (doc["entries"], doc["places_without_data"]) == (5, 2)
        table = run("info", path)
        assert table.exit_code == 0, table.stderr
        assert f"entries │ {SAID}" in _flat(table.stdout)

    out = tmp_path / "report"
    assert run("report", office.map, "-o", out, "-q").exit_code == 0
    page = _flat((out / "index.html").read_text(encoding="utf-8"))
    assert f'<td>entries</td><td class="n">{SAID}</td>' in page
