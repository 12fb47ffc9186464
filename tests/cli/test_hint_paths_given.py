"""A hint or note that gives a command to act on a file names the file by the path the user
gave, not by its bare name: ``aion predict "my dir/my log.mcap"`` hinted ``aion build 'my
log.mcap' -o MAP.aion``, which fails from where the user is (no such file there).

Every test runs from ``tmp_path`` and gives paths relative to it inside the folder ``my dir``
(a folder, and a space the shell must be told about): the command in the message, split as a
shell splits it, must name the file by that same relative path."""

from __future__ import annotations

import json
import re
import shlex
import shutil
import zipfile
from pathlib import Path

import pytest

from tests.cli.conftest import Office, run, run_json
from tests.cli.logdata import save_graph_file
from tests.formats.dataset_files import MAGNI_HEADER

FOLDER = "my dir"
THOR_ROWS = "0.02,12001,-0.046,-3.443,0.141,2.356\n0.42,12001,-0.1,-3.4,0.1,2.3\n"


def _words(said: str, command: str) -> list[str]:
    """The shell words of the command in ``said`` (wrapped lines joined) that starts with
    ``command`` and ends at a backtick, a closing parenthesis, a semicolon or the end."""
    said = " ".join(said.split())
    found = re.search(rf"{re.escape(command)}(?:'[^']*'|[^`);'])*", said)
    assert found is not None, (command, said)
    return shlex.split(found.group(0))


@pytest.fixture
def here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``tmp_path``, made the current folder, with the folder ``my dir`` in it."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / FOLDER).mkdir()
    return tmp_path


def _in_folder(source: Path, name: str) -> str:
    """A copy of ``source`` as ``my dir/<name>``: the path a user in ``tmp_path`` types."""
    shutil.copyfile(source, Path(FOLDER) / name)
    return f"{FOLDER}/{name}"


def _graph() -> str:
    save_graph_file(Path(FOLDER) / "dsg.json")
    return f"{FOLDER}/dsg.json"


def _refused(*args: str) -> str:
    result = run(*args)
    assert result.exit_code == 2, result.stderr
    assert "Traceback" not in result.stderr
    return result.stderr


# -- a file given where another kind belongs (convert_checks, mapfile_check, log_format) -----


def test_convert_names_a_log_a_map_or_a_graph_given_as_tracks_by_its_path(
    here: Path, office: Office
) -> None:
    log = _in_folder(office.log, "my log.mcap")
    said = _refused("convert", log, "--layout", "thor", "-o", "x.mcap")
    assert _words(said, "aion build") == ["aion", "build", log, "-o", "MAP.aion"]
    made = _in_folder(office.map, "my map.aion")
    said = _refused("convert", made, "--layout", "thor", "-o", "x.mcap")
    assert _words(said, "aion predict") == ["aion", "predict", made]
    graph = _graph()
    said = _refused("convert", graph, "--layout", "thor", "-o", "x.mcap")
    assert _words(said, "aion convert TRACKS") == [
        "aion", "convert", "TRACKS", "--graph", graph, "-o", "LOG"
    ]
    bag = Path(FOLDER) / "a bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    said = _refused("convert", str(bag), "--layout", "thor", "-o", "x.mcap")
    assert _words(said, "aion build") == ["aion", "build", str(bag), "-o", "MAP.aion"]


def test_a_log_or_a_graph_given_as_a_map_is_named_by_its_path(here: Path, office: Office) -> None:
    log = _in_folder(office.log, "my log.mcap")
    said = _refused("predict", log, "--time", "2026-11-23 08:10")
    assert _words(said, "aion build") == ["aion", "build", log, "-o", "MAP.aion"]
    graph = _graph()
    said = _refused("predict", graph, "--time", "2026-11-23 08:10")
    assert _words(said, "aion info") == ["aion", "info", graph]
    assert _words(said, "aion build LOG") == [
        "aion", "build", "LOG", "--graph", graph, "-o", "MAP.aion"
    ]


def test_a_map_a_graph_or_tracks_given_as_a_log_are_named_by_their_path(
    here: Path, office: Office
) -> None:
    made = _in_folder(office.map, "my map.aion")
    said = _refused("build", made, "-o", "other.aion")
    assert _words(said, "aion build LOG") == ["aion", "build", "LOG", "--map", made]
    assert _words(said, "aion predict") == ["aion", "predict", made]
    graph = _graph()
    said = _refused("build", graph, "-o", "other.aion")
    assert _words(said, "--graph") == ["--graph", graph]
    tracks = Path(FOLDER) / "run 1.csv"
    tracks.write_text(THOR_ROWS)
    said = _refused("build", str(tracks), "-o", "other.aion")
    # the log it makes is named for the current folder, where the user is
    assert _words(said, "aion convert") == [
        "aion", "convert", str(tracks), "--layout", "thor", "-o", "run 1.mcap"
    ]


# -- the iconv hints of tracks files in another encoding ---------------------------------------


def test_the_iconv_hints_name_the_tracks_file_by_its_path(here: Path) -> None:
    wide = Path(FOLDER) / "wide rows.csv"
    wide.write_bytes(THOR_ROWS.encode("utf-16"))
    said = _refused("convert", str(wide), "--layout", "thor", "-o", "w.mcap")
    assert _words(said, "iconv") == [
        "iconv", "-f", "UTF-16", "-t", "UTF-8", str(wide), ">", "wide rows-utf8.csv"
    ]
    latin = Path(FOLDER) / "magni run.csv"
    rows = [f"{k / 10:.1f},{k},{1000 + 100 * k},2000,0,Helmet_3,a,m,1" for k in range(3)]
    rows[2] = rows[2].replace("Helmet_3", "Helmet_\xe9")
    latin.write_bytes(("\n".join([MAGNI_HEADER, *rows]) + "\n").encode("latin-1"))
    said = _refused("convert", str(latin), "--layout", "thor-magni", "--start",
                    "2022-05-12 10:00", "-o", "m.mcap")
    assert _words(said, "iconv") == [
        "iconv", "-f", "LATIN1", "-t", "UTF-8", str(latin), ">", "magni run-utf8.csv"
    ]


# -- notes that tell what to run next -----------------------------------------------------------


def test_converts_notes_name_the_log_they_wrote_by_its_path(here: Path) -> None:
    tracks = Path(FOLDER) / "thor.csv"
    tracks.write_text(THOR_ROWS)
    out = f"{FOLDER}/c d.mcap"
    result = run("convert", str(tracks), "--layout", "thor", "--start", "2017-06-01 10:00",
                 "-o", out)  # a start read in UTC: the note's build gives Örebro's hours
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split()).split("if it is UTC, ")[1]
    assert _words(said, "aion build")[:5] == ["aion", "build", out, "--tz", "Europe/Stockholm"]
    zoned = f"{FOLDER}/e f.mcap"
    result = run("convert", str(tracks), "--layout", "thor", "--tz", "Europe/Stockholm",
                 "-o", zoned)
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split()).split("the log carries the zone")[-1]
    assert _words(said, "aion build")[:3] == ["aion", "build", zoned]  # then "makes a map"


def test_info_names_an_unreadable_maps_verify_by_its_path(here: Path, office: Office) -> None:
    """A map whose stored configuration is not valid: ``aion info`` still lists its members,
    with a warning whose ``--verify`` run names the map by its path."""
    made = Path(_in_folder(office.map, "my map.aion"))
    broken = made.with_name("broken map.aion")
    with zipfile.ZipFile(made) as src, zipfile.ZipFile(broken, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "manifest.json":
                manifest = json.loads(data)
                manifest["state"]["config"] = {"cell_size": "wide"}
                data = json.dumps(manifest).encode()
            dst.writestr(item, data)
    report = run_json("info", str(broken), "--format", "json")
    (warning,) = [w for w in report["warnings"] if "--verify" in w]
    assert _words(warning, "aion info") == ["aion", "info", str(broken), "--verify"]


def test_info_names_a_part_maps_merge_by_its_path(here: Path, office: Office) -> None:
    log = _in_folder(office.log, "my log.mcap")
    part = f"{FOLDER}/my part.aion"
    built = run("build", log, "--part", "-o", part, "-q")
    assert built.exit_code == 0, built.stderr
    result = run("info", part)
    assert result.exit_code == 0, result.stderr
    assert _words(result.stdout, "aion merge")[:3] == ["aion", "merge", part]
