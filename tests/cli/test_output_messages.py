"""Messages of the output commands that had misled (a bad-input sweep): an unwritable
``plan --export`` folder, a format its output's suffix disagrees with, an output named by a
suffix alone, a step giving a unit twice."""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path
from typing import Any

import pytest

from aion_cli.time_steps import Step, parse_step
from aion_cli.timeparse import TimeFormatError
from tests.cli.conftest import Office, assert_one_line_error, run

AT = "2026-11-23T08:30"
HOUR = 3600 * 10**9


def test_an_unwritable_plan_export_folder_reads_as_png_does(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A folder that refuses new files (EPERM: immutable, a read-only mount) had made
    ``--export`` print the bare "Operation not permitted: PATH" while ``--png`` said "cannot
    write PATH: ...": both now say the latter, naming the file the user gave. The refusal is
    simulated (the tests run as root, whom permissions do not stop) at the staging folder
    made beside the output, as the kernel refuses it."""
    real = tempfile.mkdtemp

    def refuse(*args: Any, **kwargs: Any) -> str:
        if str(kwargs.get("dir", "")).startswith(str(tmp_path)):
            raise PermissionError(errno.EPERM, os.strerror(errno.EPERM), kwargs["dir"])
        return real(*args, **kwargs)

    monkeypatch.setattr(tempfile, "mkdtemp", refuse)
    plan = ("plan", office.map, "--from", "p1", "--to", "p3", "-t", AT)
    for option, name in (("--export", "path.ply"), ("--png", "path.png")):
        result = run(*plan, option, tmp_path / name, "-q")
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(
            result.stderr, f"cannot write {tmp_path / name}: {os.strerror(errno.EPERM)}"
        )
        assert not (tmp_path / name).exists()


@pytest.mark.parametrize(
    ("args", "message", "hint"),
    [
        (["--format", "png", "-o", "x.mcap"],
         "the format png and the name 'x.mcap' disagree: .mcap is the suffix of format mcap",
         "name it x.png, or give the format mcap"),
        (["--format", "mcap", "-o", "x.PNG"],
         "the format mcap and the name 'x.PNG' disagree: .png is the suffix of format png",
         "name it x.mcap, or give the format png"),
        (["--format", "dsg", "-o", "x.ply"],
         "the format dsg and the name 'x.ply' disagree: .ply is the suffix of format ply",
         "name it x.json, or give the format ply"),
        (["--format", "pcd", "-o", "x.sparkdsg"],
         "the format pcd and the name 'x.sparkdsg' disagree: .sparkdsg is the suffix of "
         "format dsg", "name it x.pcd, or a folder (e.g. out/), or give the format dsg"),
        (["-o", "flows.csv"],
         "the format ply (the default) and the name 'flows.csv' disagree: .csv is the suffix "
         "of a table", "name it flows.ply, or a folder (e.g. out/); the table alone: aion "
         "predict MAP --time T --format csv > FILE.csv"),
    ],
)  # fmt: skip
def test_a_format_and_a_suffix_that_disagree_are_both_named(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str],
    message: str, hint: str,
) -> None:
    """``--format png -o x.mcap`` had said "-o writes a .png file", as if the format were
    the user's only choice: now the format and the suffix are both named, with either fix.
    Nothing is written."""
    monkeypatch.chdir(tmp_path)
    result = run("export", office.map, "-t", AT, *args, "-q")
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, message)
    assert f"hint: {hint}" in result.stderr
    assert sorted(os.listdir(tmp_path)) == []


def test_export_help_says_the_suffix_must_match_the_format() -> None:
    """The README said an ``-o`` whose suffix names another format is refused, ``export
    --help`` did not: its -o help says so, with the example the test above refuses."""
    said = " ".join(run("export", "--help").stdout.split())
    output = said.split("-o, --output PATH", 1)[1].split(" -t, --time", 1)[0]
    assert "With --format, a suffix naming another format is refused (--format png -o " \
        "x.mcap)." in output, output


@pytest.mark.parametrize("name", [".png", ".PLY", ".mcap", ".json", ".csv"])
def test_an_output_named_by_a_suffix_alone_is_refused(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str
) -> None:
    """``-o .png`` had written a hidden folder of PLY frames named ``.png`` (a dot file has
    no suffix): a name that is only a suffix is refused, nothing written; an existing folder
    of that name is still written into (the user made it)."""
    monkeypatch.chdir(tmp_path)
    result = run("export", office.map, "-t", AT, "-o", name, "-q")
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, f"{name!r} is only a suffix: name the file before it")
    assert f"hint: e.g. map{name.lower()}" in result.stderr
    assert os.listdir(tmp_path) == []
    (tmp_path / name).mkdir()
    result = run("export", office.map, "-t", AT, "-o", name, "-q")
    assert result.exit_code == 0, result.stderr
    assert "scene.ply" in os.listdir(tmp_path / name)


def test_a_step_giving_a_unit_twice_is_refused() -> None:
    """``--step 1h1h`` had been read as 2 h: a unit given twice is surely a slip, refused
    naming it ("m" and "min" are one unit); a step of several different units still adds."""
    for text, unit in (("1h1h", "h"), ("1h30m1h", "h"), ("1m1min", "m"), ("1d 2D", "d")):
        with pytest.raises(TimeFormatError) as caught:
            parse_step(text)
        assert caught.value.message == f"--step {text!r} gives the unit {unit!r} twice"
    assert parse_step("1h30m") == Step(0, HOUR + 30 * 60 * 10**9)
    assert parse_step("1d12h") == Step(1, 12 * HOUR)
    assert parse_step("1w1d") == Step(8, 0)


def test_a_step_giving_a_unit_twice_is_a_one_line_error(office: Office) -> None:
    result = run(
        "predict", office.map, "--from", AT, "--to", "2026-11-23T10:30", "--step", "1h1h"
    )
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "--step '1h1h' gives the unit 'h' twice")


def test_a_leave_of_one_time_is_one_departure(office: Office) -> None:
    """``--leave T..T`` had been refused ("the end is not after the start") while
    ``predict --from T --to T`` is a series of one time: it is the one departure T, the plan
    ``--time T`` makes; the API's ``leave=(T, T)`` likewise. An end before the start and two
    wall-clock times a clock change makes one instant are still refused."""
    import json

    import aion_cli as aion

    plan = ("plan", office.map, "--from", "p1", "--to", "p3", "--format", "json")
    one = run(*plan, "--leave", f"{AT}..{AT}")
    assert one.exit_code == 0, one.stderr
    at = run(*plan, "--time", AT)
    assert at.exit_code == 0, at.stderr
    left, timed = json.loads(one.stdout), json.loads(at.stdout)
    assert [d["depart"] for d in left["departures"]] == ["2026-11-23 08:30:00+00:00"]
    assert left.pop("departures")[0]["best"] is True
    assert left == timed
    made = aion.Map.load(office.map).plan("p1", "p3", leave=(AT, AT))
    assert made.cost == timed["temporal"]["cost"]
    assert made.depart_ns == timed["depart_ns"]
    assert [d["best"] for d in made.departures] == [True]
    back = run(*plan, "--leave", f"{AT}..2026-11-23T08:29")
    assert back.exit_code == 2
    assert_one_line_error(back.stderr, "the end is not after the start")


def test_an_observed_span_of_one_time_is_refused_saying_why(
    office: Office, tmp_path: Path
) -> None:
    """``T..T`` is one departure for ``--leave`` (above) but no span a sensor recorded: build
    and ``evaluate holdout`` refuse ``--observed T..T``, and the hint had only asked for an
    END later than START, as for a reversed span; it says that T..T is one instant, which
    only ``--leave`` takes. A reversed span keeps the plain hint."""
    point = f"{AT}..{AT}"
    why = "--observed takes a span of time, and T..T is one instant (only --leave takes it"
    for command in (("build", office.log, "-o", tmp_path / "m.aion"),
                    ("evaluate", "holdout", office.map, office.log)):  # fmt: skip
        refused = run(*command, "--observed", point)
        assert refused.exit_code == 2, refused.stderr
        assert_one_line_error(refused.stderr, f"--observed '{point}': the end is not after")
        assert why in refused.stderr
        back = run(*command, "--observed", f"{AT}..2026-11-23T08:29")
        assert back.exit_code == 2, back.stderr
        assert "hint: give the span as START..END with END later than START\n" in back.stderr
    assert not (tmp_path / "m.aion").exists()
    left = run("plan", office.map, "--from", "p1", "--to", "p3", "--leave", point)
    assert left.exit_code == 0, left.stderr
    import aion_cli as aion
    from aion_cli.errors import InputError

    with pytest.raises(InputError, match="the end is not after the start") as caught:
        aion.build(office.log, tmp_path / "api.aion", observed=[(AT, AT)])
    assert "(T, T) is one instant (only Map.plan's leave takes it" in (caught.value.hint or "")


def test_info_describes_a_scene_aion_exported_without_warnings(
    office: Office, tmp_path: Path
) -> None:
    """``aion info`` of an MCAP scene aion exported had warned that /aion/scene is "not
    ROS" and skipped /aion/markers as generic markers: it says what each topic holds and how
    many steps the scene has, from when to when, with no warning."""
    import json

    out = tmp_path / "scene.mcap"
    series = ("--from", "2026-11-23T08:00", "--to", "2026-11-23T09:00", "--step", "30m")
    assert run("export", office.map, *series, "-o", out, "-q").exit_code == 0
    shown = run("info", out)
    assert shown.exit_code == 0, shown.stderr
    said = " ".join(shown.stderr.split())
    assert "warning" not in said, said
    assert (
        "it is a scene aion exported, to open in Foxglove or RViz: 3 steps from "
        "2026-11-23 08:00:00 to 2026-11-23 09:00:00" in said  # on the header's clock, UTC
    ), said
    assert "no scene graph" not in said, said  # a scene, not a log to build from
    tracks = tmp_path / "t.csv"  # a log without a graph keeps the note
    tracks.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n1780000000000000000,1,0,0,0,0,1\n")
    assert run("convert", tracks, "-o", tmp_path / "t.mcap", "-q").exit_code == 0
    assert "note: no scene graph: build with" in run("info", tmp_path / "t.mcap").stderr
    report = json.loads(run("info", out, "--format", "json").stdout)
    assert report["warnings"] == []
    why = {t["topic"]: t["why"] for t in report["topics"]}
    assert why["/aion/scene"] == "the scene at each step, for Foxglove (aion export --format mcap)"
    assert why["/aion/markers"].startswith("the scene at each step as markers, for RViz")
    assert {t["topic"]: t["count"] for t in report["topics"]}["/aion/scene"] == 3


def test_info_on_a_folder_named_as_a_map_says_it_is_a_folder(
    office: Office, tmp_path: Path
) -> None:
    """``aion info dir.aion`` had said the folder is not a rosbag2 bag: it says the folder is
    no map file, and what one is (or names the maps inside it)."""
    import shutil

    folder = tmp_path / "dir.aion"
    folder.mkdir()
    result = run("info", folder)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, f"{folder} is a folder, not a map file")
    assert "rosbag2" not in result.stderr
    assert "hint: give a map file (maps end in .aion" in result.stderr
    shutil.copy(office.map, folder / "office.aion")
    result = run("info", folder)
    assert result.exit_code == 2
    assert f"hint: give a map in it: {folder / 'office.aion'}" in result.stderr
