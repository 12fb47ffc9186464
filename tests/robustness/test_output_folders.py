"""Every writing command treats a missing folder above its output alike: refused before any
work with one ``error:`` line naming the folder, a hint, exit 2, and no folder made
(:func:`formats.outputs.check_output_folder`). ``convert``, ``simulate``, ``export``,
``report`` and ``plan --export`` used to make the folders (``-o tpyo/run.mcap`` put the log
where nobody looked) while ``build``, ``merge``, ``compact`` and the PNG writers refused them.
An output that is itself a folder (``export -o DIR``, ``report -o DIR``, ``simulate --scenes``)
is still made when the folder above it exists.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.robustness.conftest import Office, fails, run
from tests.robustness.test_outputs import tracks_csv

AT = "2026-01-05 10:00"

WRITERS: dict[str, tuple[str, ...]] = {
    "build": ("build", "{log}", "-o", "{out}/x.aion"),
    "merge": ("merge", "{map}", "-o", "{out}/x.aion"),
    "compact": ("compact", "{map}", "-o", "{out}/x.aion"),
    "convert": ("convert", "{csv}", "-o", "{out}/x.mcap"),
    "simulate": ("simulate", "-o", "{out}/x.mcap", "--days", "0.05", "-q"),
    "simulate --scenes": ("simulate", "-o", "{out}/scenes", "--scenes", "2", "--days", "0.05"),
    "export DIR": ("export", "{map}", "--historical", "-o", "{out}/scene"),
    "export .ply": ("export", "{map}", "--historical", "-o", "{out}/x.ply"),
    "export .png": ("export", "{map}", "--historical", "-o", "{out}/x.png"),
    "export .mcap": ("export", "{map}", "--historical", "-o", "{out}/x.mcap"),
    "export .json": ("export", "{map}", "--historical", "-o", "{out}/x.json"),
    "report": ("report", "{map}", "-o", "{out}/report"),
    "plan --export": ("plan", "{map}", "--from", "p1", "--to", "p2", "--time", AT,
                      "--export", "{out}/x.ply"),
}  # fmt: skip


def _args(template: tuple[str, ...], office: Office, csv: Path, out: Path) -> list[str]:
    names = {"log": office.log, "map": office.map, "csv": csv, "out": out}
    return [part.format(**names) for part in template]


@pytest.mark.parametrize("command", sorted(WRITERS))
def test_a_missing_folder_above_the_output_is_refused(
    office: Office, tmp_path: Path, command: str
) -> None:
    """Before: convert, simulate, export, report and plan --export made ``missing/``."""
    csv = tracks_csv(tmp_path / "tracks.csv")
    missing = tmp_path / "missing"
    result = run(*_args(WRITERS[command], office, csv, missing))
    fails(result, "cannot write", f"the folder {missing} does not exist")
    assert "mkdir -p" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tracks.csv"]  # nothing made


@pytest.mark.parametrize("command", ["export DIR", "report", "simulate --scenes"])
def test_an_output_that_is_a_folder_is_made_in_an_existing_one(
    office: Office, tmp_path: Path, command: str
) -> None:
    csv = tracks_csv(tmp_path / "tracks.csv")
    result = run(*_args(WRITERS[command], office, csv, tmp_path))
    assert result.exit_code == 0, result.stderr
    made = [p for p in tmp_path.iterdir() if p.name != "tracks.csv"]
    assert len(made) == 1
    assert made[0].is_dir()
    assert any(made[0].iterdir())


@pytest.mark.parametrize(
    ("command", "name"),
    [("report", "report.html"), ("export DIR", "map.jpg"), ("export DIR", "scene.aion"),
     ("report", "site.aion")],
)  # fmt: skip
def test_a_new_output_folder_named_as_a_file_is_refused(
    office: Office, tmp_path: Path, command: str, name: str
) -> None:
    """``report -o report.html`` wrote report.html/index.html (a folder a browser is given
    as a page), ``export -o map.jpg`` a folder of PLY files named as a picture: refused, the
    name without the suffix as hint, nothing made. A folder already so named is written into."""
    template = (*WRITERS[command][:-1], "{out}")  # -o the folder itself
    out = tmp_path / name
    result = run(*_args(template, office, tmp_path / "none.csv", out))
    bare = out.with_suffix("")
    fails(result, f"{out} would be a new folder named as a {out.suffix} file")
    assert f"e.g. {bare}/" in result.stderr
    assert not out.exists()
    assert not bare.exists()
    out.mkdir()  # the user's own folder of that name
    again = run(*_args(template, office, tmp_path / "none.csv", out))
    assert again.exit_code == 0, again.stderr
    assert any(out.iterdir())


def test_evaluate_report_refuses_a_new_folder_named_as_its_page(tmp_path: Path) -> None:
    """``aion evaluate report -o report.md`` made a folder report.md holding report.md."""
    out = tmp_path / "report.md"
    result = run("evaluate", "report", "-o", out, "--data", tmp_path / "none",
                 "--skip", "office", "--skip", "atc", "--skip", "lincoln")  # fmt: skip
    fails(result, f"{out} would be a new folder named as a .md file")
    assert f"e.g. {tmp_path / 'report'}/" in result.stderr
    assert not out.exists()
