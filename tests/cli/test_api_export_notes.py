"""``Map.export``'s ``notes`` are the notes ``aion export`` prints beside the files: they were a
spark_dsg file's only, so a script never learnt that a shorter series had removed an earlier
series' frames from its folder, that a path drawn with ``historical=True`` is the shortest by
distance, or what the forecast at the export's time cannot say (which ``Map.predict`` gives in
its table's ``notes``)."""

from __future__ import annotations

from pathlib import Path

import pytest

import aion_cli as aion
from tests.cli.conftest import Office, run

LONGER = ("2026-01-12 06:00", "2026-01-12 09:00")
SHORTER = ("2026-01-12 06:00", "2026-01-12 07:00")
LATE = "2027-06-01 08:00"  # over a year after the office log's Monday: the forecast says so


@pytest.fixture(scope="module")
def m(office: Office) -> aion.Map:
    return aion.Map.load(office.map)


def _said(stderr: str) -> str:
    return " ".join(stderr.split())  # the terminal's line breaks undone


def test_a_shorter_series_notes_the_frames_it_removed(
    m: aion.Map, office: Office, tmp_path: Path
) -> None:
    out = tmp_path / "series"
    m.export(out, series=LONGER, step="1h", tz="UTC")
    assert len(list(out.glob("2026*"))) == 4
    files = m.export(out, series=SHORTER, step="1h", tz="UTC")
    assert sorted(p.name for p in out.glob("2026*")) == ["20260112T060000Z", "20260112T070000Z"]
    removed = (
        "what an earlier series wrote for times this one has not: 2 frame(s) "
        "(20260112T080000Z to 20260112T090000Z)"
    )
    assert f"removed from {out} {removed}" in files.notes
    # the command notes the same of the same folder
    cli = tmp_path / "cli"
    for a, b in (LONGER, SHORTER):
        result = run("export", office.map, "--from", a, "--to", b, "--step", "1h", "-o", cli)
        assert result.exit_code == 0, result.stderr
    assert f"removed from {cli} {removed}" in _said(result.stderr)
    # a series that removes nothing says nothing of it
    again = m.export(out, series=SHORTER, step="1h", tz="UTC")
    assert not [n for n in again.notes if "earlier series" in n]


def test_a_path_drawn_as_observed_is_noted_as_the_shortest(m: aion.Map, tmp_path: Path) -> None:
    files = m.export(tmp_path / "h", historical=True, path=("p0", "p4"))
    assert files.notes == (
        "historical=True has no time to forecast a path's costs at: the path drawn is the "
        "shortest by distance (give time= for one that avoids busy, opposing flows)",
    )
    assert m.export(tmp_path / "h2", historical=True).notes == ()


def test_an_export_notes_what_its_forecast_cannot_say(
    m: aion.Map, office: Office, tmp_path: Path
) -> None:
    """The notes of a prediction at the export's time (and of a series at its times) come
    first, as the command prints them before the files."""
    told = m.predict(LATE, tz="UTC").notes
    assert told, "the office map says nothing of a time a year after it: pick another"
    files = m.export(tmp_path / "late", time=LATE, tz="UTC")
    assert files.notes == told
    result = run("export", office.map, "--time", LATE, "--tz", "UTC", "-o", tmp_path / "cli")
    assert result.exit_code == 0, result.stderr
    for note in told:
        assert _said(note) in _said(result.stderr)
    series = ("2027-06-01 06:00", "2027-06-01 09:00")
    told = m.predict_series(*series, "1h", tz="UTC").notes
    assert m.export(tmp_path / "s", series=series, step="1h", tz="UTC").notes == told
