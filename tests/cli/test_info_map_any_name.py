"""``aion info`` on a map whose name does not end in .aion. ``aion compact MAP -o x.txt`` and
``aion build LOG -o x.map`` write a valid map under any name, but ``aion info x.txt`` told the
map from a log by its suffix alone and said "cannot tell the log format". It now tells a map
by its content (a zip holding the map's manifest), whatever its name; a zip that is no map
is still refused with one line."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import pytest

from tests.cli.conftest import Office, assert_one_line_error, run, run_json


@pytest.mark.parametrize("name", ["x.txt", "x.map", "noname"])
def test_a_map_of_any_name_is_described_as_the_same_map_named_aion(
    office: Office, tmp_path: Path, name: str
) -> None:
    renamed = tmp_path / name
    shutil.copyfile(office.map, renamed)
    same = run_json("info", office.map, "--format", "json")
    doc = run_json("info", renamed, "--format", "json")
    assert doc["map"] == str(renamed)
    same.pop("map")
    doc.pop("map")
    assert doc == same  # format, inputs, counts, families...: the same map
    table = run("info", renamed)
    assert table.exit_code == 0, table.stderr
    assert f"map {renamed}" in " ".join(table.stdout.split())
    assert "cannot tell the log format" not in table.stderr
    mixed = run("info", renamed, office.log)  # with a log: the map is named as a map
    assert mixed.exit_code == 2
    assert_one_line_error(mixed.stderr, "give either logs or maps")
    assert f"{name} is a map" in mixed.stderr


def test_a_zip_that_is_no_map_is_refused_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "photos.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("a.txt", "not a map")
    result = run("info", path)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "photos.zip")
