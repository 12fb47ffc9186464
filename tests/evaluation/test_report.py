"""The markdown report: sections, tables and PNG plots are written."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.evaluation.atc import AtcResult
from aion_cli.evaluation.report import atc_section, write_report
from tests.shared_data import SHARED_DATA

DATA = SHARED_DATA


@pytest.mark.skipif(
    not (DATA / "fremen_door" / "training_data.txt").is_file(),
    reason="the door data (../shared/data/fremen_door) is not here",
)
def test_door_only_report_has_table_and_plot(tmp_path: Path) -> None:
    path = write_report(tmp_path, DATA, skip={"office", "atc"})
    text = path.read_text()
    assert "## FreMEn on the real door signal" in text
    assert text.count("\n| ") >= 9
    assert (tmp_path / "door.png").stat().st_size > 1000
    assert (tmp_path / "results.json").exists()


def test_atc_section_plots_nll_per_hour(tmp_path: Path) -> None:
    result = AtcResult("random", 1.0, 100)
    for hour in (9, 10):
        for model, nll in (("aion", 1.4), ("grid", 1.6)):
            result.rows.append({"hour": hour, "model": model, "detections": 10, "matched": 9,
                                "unmatched": 1, "nll_matched": nll, "nll_all": nll + 0.01,
                                "chi_square": 0.5})
    lines = atc_section({"random": result}, tmp_path)
    assert any(line.startswith("| aion |") for line in lines)
    assert (tmp_path / "atc_random_nll.png").stat().st_size > 1000


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"skip": {"office", "atc", "lincoln", "door"}}, "every section is skipped"),
        ({"skip": {"office"}, "data": "none"}, "atc data folder not found"),
        ({"skip": {"atc", "lincoln", "door"}, "days": float("nan")}, "--days must be"),
    ],
)
def test_a_report_that_cannot_be_made_writes_nothing(
    tmp_path: Path, kwargs: dict[str, object], fragment: str
) -> None:
    from aion_cli.errors import InputError

    out = tmp_path / "report"
    data = tmp_path / "none" if kwargs.pop("data", None) else DATA
    with pytest.raises(InputError, match=fragment):
        write_report(out, data, scenes=1, **kwargs)  # type: ignore[arg-type]
    assert not out.exists()  # no empty folder left behind


@pytest.mark.parametrize(
    ("name", "content"),
    [
        ("report.md", b"# my notes on the robot\n"),
        ("results.json", b'{"mine": 1}\n'),
        ("door.png", b"\x89PNG\r\n\x1a\n a picture of mine"),
    ],
)
def test_a_file_of_someone_elses_under_a_report_name_is_refused(
    tmp_path: Path, name: str, content: bytes
) -> None:
    """``evaluate report -o DIR`` wrote over a report.md, results.json or door.png of the
    user's own in DIR without a word. Now it is refused before anything runs, as aion report
    and aion export refuse such files, and the file is left as it was."""
    from aion_cli.formats.outputs import OutputPathError

    (tmp_path / name).write_bytes(content)
    with pytest.raises(OutputPathError, match=f"{name} exists and is another file"):
        write_report(tmp_path, DATA, skip={"office", "atc", "lincoln"})
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]  # nothing written beside it
    assert (tmp_path / name).read_bytes() == content


@pytest.mark.skipif(
    not (DATA / "fremen_door" / "training_data.txt").is_file(),
    reason="the door data (../shared/data/fremen_door) is not here",
)
def test_a_report_replaces_its_own_files(tmp_path: Path) -> None:
    first = write_report(tmp_path, DATA, skip={"office", "atc", "lincoln"}).read_text()
    (tmp_path / "office_directions.png").write_bytes(b"not drawn by aion")  # not written now
    again = write_report(tmp_path, DATA, skip={"office", "atc", "lincoln"}).read_text()
    assert again == first
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "door.png", "office_directions.png", "report.md", "results.json"
    ]


def test_a_report_that_fails_in_a_section_leaves_no_folder_behind(tmp_path: Path) -> None:
    """``evaluate report -o new/ --days 0.2``: the office section fails (the robot saw nobody
    before 07:00), and an empty ``new/`` was left behind, as if a report were there."""
    from aion_cli.errors import InputError

    out = tmp_path / "report"
    with pytest.raises(InputError, match="the robot detected nobody"):
        write_report(out, DATA, scenes=1, days=0.2, skip={"atc", "lincoln", "door"})
    assert not out.exists()
    kept = tmp_path / "kept"  # a folder that was there before is left, with what it held
    kept.mkdir()
    (kept / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match="the robot detected nobody"):
        write_report(kept, DATA, scenes=1, days=0.2, skip={"atc", "lincoln", "door"})
    assert sorted(p.name for p in kept.iterdir()) == ["notes.txt"]


def test_the_atc_section_notes_hours_without_training_data(tmp_path: Path) -> None:
    """The real ATC folder has no atc-1024-12_train.csv: aion evaluate atc notes that 12:00
    is scored by models that never saw that hour (text and JSON), the report's ATC section
    said nothing of it. A folder of hours 11 and 12, the 12:00 training file left out,
    run as the report runs it."""
    import shutil

    from aion_cli.evaluation.atc import run_atc

    atc = SHARED_DATA / "atc"
    if not (atc / "atc-1024-11_train.csv").is_file():
        pytest.skip("the ATC data (../shared/data/atc) is not here")
    folder = tmp_path / "atc"
    folder.mkdir()
    names = ("atc-1024-11_train.csv", "atc-1024-11_test.csv", "atc-1024-12_test.csv")
    for name in names:
        shutil.copy(atc / name, folder / name)
    result = run_atc(folder, "random")
    assert result.hours_without_training == [12]
    text = "\n".join(atc_section({"random": result}, tmp_path))
    assert (
        "Note: 12:00 has no training data (atc-1024-12_train.csv not in the folder): its test "
        "people are scored by models trained on the other hours only."
    ) in text
