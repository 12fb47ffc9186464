"""`aion evaluate` through click's runner and a real subprocess."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from aion_cli.cli.main import cli
from tests.shared_data import SHARED_DATA, needs, writable_copy

DATA = SHARED_DATA
AION = Path(sys.executable).parent / "aion"


@needs(DATA / "fremen_door", "the FreMEn door data")
def test_door_json_reports_every_test_week() -> None:
    result = CliRunner().invoke(
        cli, ["evaluate", "door", "--data", str(DATA / "fremen_door"), "--format", "json"],
        standalone_mode=False,
    )
    assert result.return_value == 0
    payload = json.loads(result.stdout)
    assert [w["week"] for w in payload["weeks"]] == list(range(1, 10))
    assert payload["fremen_wins"] == 9
    assert 24.0 in payload["strongest_periods_h"]
    table = CliRunner().invoke(
        cli, ["evaluate", "door", "--data", str(DATA / "fremen_door")], standalone_mode=False
    )
    assert "FreMEn beats the static mean on 9 of 9 test weeks" in table.stderr


def test_missing_data_folder_is_a_one_line_error(tmp_path: Path) -> None:
    proc = subprocess.run(
        [str(AION), "evaluate", "atc", "--data", str(tmp_path / "nope")],
        capture_output=True, text=True, check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.startswith("error: ATC data folder not found")
    assert "Traceback" not in proc.stderr


def test_office_table_says_how_the_forecast_meets_the_truth() -> None:
    """`aion evaluate office` in table form prints Table I and one line against the ground
    truth whose figures are the JSON's scene means."""
    result = CliRunner().invoke(
        cli,
        ["evaluate", "office", "--scenes", "2", "--days", "0.5", "--format", "table"],
        standalone_mode=False,
    )
    assert result.exception is None, result.output
    line = next(x for x in result.stdout.splitlines() if x.startswith("against the ground truth"))
    assert "with the expected flow" in line
    assert "previous day" in line


@needs(DATA / "lincoln" / "2017-06-09.txt", "the Lincoln corridor data")
def test_a_lincoln_day_not_recorded_is_a_one_line_error() -> None:
    proc = subprocess.run(
        [str(AION), "evaluate", "lincoln", "--data", str(DATA / "lincoln"),
         "--train", "2017-05-24, 2017-05-25", "--test", "2017-06-10"],
        capture_output=True, text=True, check=False,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert lines[0] == f"error: Lincoln days not in {DATA / 'lincoln'}: 2017-06-10"
    assert lines[1].startswith("hint: the files hold 2017-05-24, 2017-05-25")
    assert "Traceback" not in proc.stderr


@needs(DATA / "fremen_door", "the FreMEn door data")
def test_the_data_folder_is_found_from_any_folder(tmp_path: Path) -> None:
    """Without --data, from a folder with no ../shared/data beside it: $AION_SHARED_DATA,
    else the shared data beside the checkout aion runs from; a wrong variable is named."""
    import os

    env = {k: v for k, v in os.environ.items() if k != "AION_SHARED_DATA"}
    far = tmp_path / "a" / "b"
    far.mkdir(parents=True)
    for extra in ({}, {"AION_SHARED_DATA": str(DATA)}):
        proc = subprocess.run(
            [str(AION), "evaluate", "door", "--format", "json"],
            capture_output=True, text=True, check=False, cwd=far, env={**env, **extra},
        )
        if not extra and not (Path(__file__).resolve().parents[3] / "shared" / "data").is_dir():
            continue  # a checkout without shared data beside it: only the variable finds it
        assert proc.returncode == 0, proc.stderr
        assert json.loads(proc.stdout)["fremen_wins"] == 9
    proc = subprocess.run(
        [str(AION), "evaluate", "door"], capture_output=True, text=True, check=False, cwd=far,
        env={**env, "AION_SHARED_DATA": str(tmp_path / "none")},
    )
    assert proc.returncode == 2
    assert proc.stderr.startswith(f"error: door data folder not found: {tmp_path / 'none'}")
    assert "AION_SHARED_DATA" in proc.stderr


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["office", "--days", "nan"], "--days must be a positive number"),
        (["office", "--seed", "-1"], "--seed must be a whole number"),
        (["office", "--radius", "-1"], "association radius"),
        (["office", "--radius", "nan"], "association radius"),
        (["office", "--config", "BINS4"], "keeps 8 direction bins"),
        # 00:00-02:24: nobody at work yet (the hint named --detections-topic, not an option)
        (["office", "--days", "0.1"], "the robot detected nobody in 0.1 simulated day(s)"),
        (["report", "-o", "REPORT", "--days", "nan"], "--days must be a positive number"),
    ],
)
def test_evaluate_office_refuses_numbers_it_cannot_run_with(
    args: list[str], fragment: str, tmp_path: Path
) -> None:
    """Each was an internal error, or a table computed with a nonsense radius; each is one
    error line and a hint (--days nan, which click's range lets through, and --seed -1 had
    no hint)."""
    config = tmp_path / "bins4.toml"
    config.write_text("bins = 4\n")
    given = {"BINS4": str(config), "REPORT": str(tmp_path / "report")}
    argv = [given.get(a, a) for a in args]
    proc = subprocess.run(
        [str(AION), "evaluate", *argv, "--scenes", "1"], capture_output=True, text=True,
        check=False,
    )
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.split("error: ", 1)[1].splitlines()  # after any progress line
    assert len(lines) == 2, proc.stderr
    assert lines[1].startswith("hint: "), proc.stderr
    assert fragment in lines[0], proc.stderr


@needs(DATA / "fremen_door", "the FreMEn door data")
@pytest.mark.parametrize(
    ("name", "text", "fragment"),
    [
        ("training_data.txt", "", "no rows"),
        ("training_data.txt", "KEEP\nnan\n", "not a table of numbers"),
        ("test_data_1.txt", "abc\n", "not a table of numbers"),
        ("test_data_1.txt", "0\n1\n0\n1\n0\n", "times but 5 states"),
        ("test_times_1.txt", "", "no rows"),
    ],
)
def test_damaged_door_files_are_one_line_errors(
    tmp_path: Path, name: str, text: str, fragment: str
) -> None:
    """Each was an internal error (or a success table of a week without samples)."""
    data = writable_copy(DATA / "fremen_door", tmp_path / "door")
    original = (data / name).read_text()
    (data / name).write_text(text.replace("KEEP\n", original))
    proc = subprocess.run(
        [str(AION), "evaluate", "door", "--data", str(data)],
        capture_output=True, text=True, check=False,
    )
    assert proc.returncode == 2, proc.stderr
    assert fragment in proc.stderr
    assert "Traceback" not in proc.stderr


@needs(DATA / "fremen_door", "the FreMEn door data")
@pytest.mark.parametrize("rows", [3, 1440])
def test_door_training_too_short_to_score_a_day_is_an_error(tmp_path: Path, rows: int) -> None:
    """Three minutes, or the first day alone: no day is scored, every family's score is 0,
    and the table called FreMEn order 1 'the best by day-ahead score' of periods of amplitude
    0 (exit 0)."""
    data = writable_copy(DATA / "fremen_door", tmp_path / "door")
    lines = (data / "training_data.txt").read_text().splitlines(keepends=True)
    (data / "training_data.txt").write_text("".join(lines[:rows]))
    result = CliRunner().invoke(cli, ["evaluate", "door", "--data", str(data)])
    assert result.exit_code == 2, result.output
    assert "no day of the training data could be scored" in result.stderr
    assert "best day-ahead score" not in result.output


@needs(DATA / "lincoln" / "2017-05-25.txt", "the Lincoln corridor data")
def test_the_lincoln_title_counts_the_detections_it_scores() -> None:
    """The heading table scores the test detections with a heading; its title says how many
    of the day's (it gave the day's total as the number scored)."""
    runner = CliRunner()
    args = ["evaluate", "lincoln", "--data", str(DATA / "lincoln"), "--train", "2017-05-24",
            "--test", "2017-05-25"]
    doc = json.loads(runner.invoke(cli, [*args, "--format", "json"]).stdout)
    scored = doc["headings"][0]["detections"]
    total = doc["data"]["2017-05-25"]["detections"]
    assert 0 < scored < total
    shown = " ".join(runner.invoke(cli, [*args, "--format", "table"]).stdout.split())
    assert f"on the {scored:,} test detections with a heading (of {total:,}" in shown


@needs(DATA / "lincoln" / "2017-05-26.txt", "the Lincoln corridor data")
def test_a_lincoln_training_day_after_the_test_day_is_warned_of() -> None:
    """Training on May 26 to forecast May 25 judges the forecast on the past: a warning
    (on stderr, also with -q and --format json; JSON warnings) naming the later day, where
    there was none; a split in time order gets none."""
    runner = CliRunner()
    base = ["evaluate", "lincoln", "--data", str(DATA / "lincoln"), "--test", "2017-05-25"]
    result = runner.invoke(cli, [*base, "--train", "2017-05-24,2017-05-26", "--format", "json",
                                 "-q"])
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split())
    assert said.startswith("warning: 1 of the 2 training days (2017-05-26) comes after the test "
                           "day 2017-05-25")
    assert json.loads(result.stdout)["warnings"] == [said.removeprefix("warning: ")]
    ordered = runner.invoke(cli, [*base, "--train", "2017-05-24", "--format", "json", "-q"])
    assert ordered.exit_code == 0, ordered.stderr
    assert "warning" not in ordered.stderr
    assert json.loads(ordered.stdout)["warnings"] == []


def test_one_scene_prints_no_zero_spread_and_no_negative_zero() -> None:
    """Table I of one scene printed every cell of ours as 'x ± 0.00' (the spread of one
    value); it prints the mean alone, the paper's cells keep theirs. Values that round to
    zero read 0.00 / +0.000, never -0.00 (the direction and truth sentences too)."""
    from aion_cli.cli.evaluate_columns import TABLE_I_COLUMNS
    from aion_cli.evaluation.office_directions import direction_truth_sentence
    from aion_cli.evaluation.office_truth import truth_sentence

    result = CliRunner().invoke(cli, ["evaluate", "office", "--scenes", "1", "--days", "1",
                                      "-q"])
    assert result.exit_code == 0, result.output
    table = result.stdout
    assert "1 office scene x " in table  # one scene, said so
    assert "office scenes" not in table
    assert "± 0.00" not in table
    assert "0.49 ± 0.13" in table  # the paper's Entropy/Historical JS
    row = next(line for line in table.splitlines() if "Entropy" in line and "Historical" in line)
    ours = row.split("│")[3].strip()  # JS (ours): one number, two decimals
    assert re.fullmatch(r"\d+\.\d\d", ours), ours
    cell = {c.key: c.fmt for c in TABLE_I_COLUMNS}
    assert cell["js"]((0.2512, 0.0)) == "0.25"
    assert cell["js"]((0.2512, 0.031)) == "0.25 ± 0.03"
    assert cell["circular_correlation"]((-0.0004, 0.0)) == "0.00"
    assert cell["circular_correlation"]((-0.0004, 0.0123)) == "0.00 ± 0.01"
    zero = (-0.0001, 0.0)
    said = direction_truth_sentence([{"map": "aion historical", "js": (0.3, 0.0),
                                      "dominant_deg": (-0.01, 0.0), "entropy_error": zero,
                                      "entropy_bias": zero}])
    assert said.endswith("aion historical JS 0.300, dominant 0.0 deg, entropy 0.000 (+0.000)")
    assert "correlates 0.000 with" in truth_sentence({"flow_correlation": -0.0001})


def test_a_keep_folder_of_an_earlier_run_is_refused_before_any_scene(tmp_path: Path) -> None:
    """A second ``evaluate office --keep DIR`` into the same folder simulated and built every
    scene before the first one it held, then failed with a hint to ``add --force``, which
    evaluate office does not have. Now it is refused first, with a way out it has."""
    kept = tmp_path / "kept"
    kept.mkdir()
    earlier = kept / "scene_01.mcap"
    earlier.write_bytes(b"an earlier run's log")
    result = CliRunner().invoke(
        cli, ["evaluate", "office", "--scenes", "2", "--days", "0.5", "--keep", str(kept)]
    )
    assert result.exit_code == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert lines[0] == f"error: --keep {kept} holds scene_01.mcap (an earlier run's scenes?)"
    assert lines[1].startswith("hint: ")
    assert "--force" not in lines[1]
    assert sorted(p.name for p in kept.iterdir()) == ["scene_01.mcap"]  # nothing simulated
    assert earlier.read_bytes() == b"an earlier run's log"
    help_text = CliRunner().invoke(cli, ["evaluate", "office", "--help"]).stdout
    assert set(re.findall(r"--[a-z-]+", lines[1])) <= set(re.findall(r"--[a-z-]+", help_text))


@pytest.mark.parametrize(
    ("command", "sub"), [("atc", "atc"), ("lincoln", "lincoln"), ("door", "fremen_door")]
)
def test_the_shared_data_folder_as_a_datasets_data_names_the_folder_to_give(
    tmp_path: Path, command: str, sub: str
) -> None:
    """``evaluate report --data`` takes the shared folder, the others the dataset's own: the
    shared one given to them said 'no ATC files ... hint: check the path and its
    permissions' (door: 'training_data.txt not found, pass the folder with --data')."""
    for name in ("atc", "lincoln", "fremen_door"):
        (tmp_path / name).mkdir()
    result = CliRunner().invoke(cli, ["evaluate", command, "--data", str(tmp_path)])
    assert result.exit_code == 2, result.stderr
    error, hint = result.stderr.strip().splitlines()
    assert error.startswith(f"error: --data {tmp_path} is the shared data folder")
    assert hint == (
        f"hint: give --data {tmp_path / sub} (only evaluate report takes the shared folder)"
    )


@pytest.mark.parametrize("command", ["office", "report"])
def test_more_days_than_a_simulated_scene_holds_are_refused_before_any_runs(
    tmp_path: Path, command: str
) -> None:
    """--days took up to 60, but a simulated scene holds 34.7 days at 2 Hz (its robot per
    tick in memory; aion simulate refuses more): --days 40 ran for hours, unchecked."""
    from aion_cli.cli.evaluate import OFFICE_MAX_DAYS
    from aion_cli.sim.scenario import MAX_TICKS, ScenarioConfig

    assert OFFICE_MAX_DAYS * 86400 * ScenarioConfig().rate_hz <= MAX_TICKS
    out = ["-o", str(tmp_path / "report")] if command == "report" else []
    result = CliRunner().invoke(
        cli, ["evaluate", command, *out, "--scenes", "1", "--days", "40"]
    )
    assert result.exit_code == 2, result.stderr
    assert f"40.0 is not in the range 0.1<=x<={OFFICE_MAX_DAYS}" in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_seed_simulate_refuses_is_refused_with_this_commands_hint() -> None:
    """A seed beyond 2**63 - 1 ran (aion simulate refuses it): the scenes were never checked."""
    result = CliRunner().invoke(
        cli, ["evaluate", "office", "--scenes", "1", "--seed", str(2**63)]
    )
    assert result.exit_code == 2, result.stderr
    assert result.stderr.splitlines() == [
        f"error: --seed must be a whole number 0 .. {2**63 - 1}",
        "hint: see aion evaluate office --help",
    ]


def test_the_library_refuses_them_too() -> None:
    from aion_cli.errors import InputError
    from aion_cli.evaluation.office import run_office

    with pytest.raises(InputError, match=r"--days 40 is more than a simulated scene holds \(34.7"):
        run_office(scenes=1, days=40)


@pytest.mark.parametrize(
    ("command", "name"),
    [("atc", "atc-1024-9_test.csv"), ("lincoln", "2017-06-09.txt"), ("door", "training_data.txt")],
)
def test_a_datasets_file_as_data_names_its_folder(tmp_path: Path, command: str, name: str) -> None:
    """``--data .../training_data.txt`` said 'door data folder not found: .../training_data.txt'
    with a hint to pass --data, which it had."""
    given = tmp_path / name
    given.write_text("1 0\n")
    result = CliRunner().invoke(cli, ["evaluate", command, "--data", str(given)])
    assert result.exit_code == 2, result.stderr
    error, hint = result.stderr.strip().splitlines()
    assert error.startswith(f"error: --data {given} is a file: ")
    assert hint == f"hint: give --data {tmp_path}"


def test_office_json_gives_counts_as_integers() -> None:
    """`evaluate office --format json` gave each scene's counts as floats ("places_compared":
    128.0, "cells": 59.0): counts of places and cells are whole numbers, so JSON integers."""
    result = CliRunner().invoke(
        cli, ["evaluate", "office", "--scenes", "2", "--days", "1", "--format", "json", "-q"]
    )
    assert result.exit_code == 0, result.output
    scene = json.loads(result.stdout)["scenes"][0]
    counts = {
        "places_compared": scene["truth"]["places_compared"],
        "places_seen_all_day": scene["truth"]["places_seen_all_day"],
        "directions places": scene["directions"]["places"],
        "Direction/Historical cells": scene["table"]["Direction/Historical"]["cells"],
    }
    for name, value in counts.items():
        assert type(value) is int, (name, value)
    # places compared with the truth: a subset of the map's places, some of them
    assert 0 < counts["directions places"] <= counts["places_compared"] <= scene["nodes"]
    assert 0 <= counts["places_seen_all_day"] <= counts["places_compared"]
    # the predicted rows average over the evaluated hours: their cells are a mean, named so
    predicted = scene["table"]["Direction/Predicted"]
    assert "cells" not in predicted
    assert isinstance(predicted["mean_cells"], float)
    assert predicted["mean_cells"] > 0
    assert not re.search(r'"(places_compared|places_seen_all_day|places|cells)": \d+\.0\b',
                         result.stdout)


@pytest.mark.parametrize(
    ("command", "folder"), [("atc", "atc"), ("door", "fremen_door"), ("lincoln", "lincoln")]
)
def test_the_data_default_in_help_is_the_folder_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, command: str, folder: str
) -> None:
    """--data's default as --help gives it, $AION_SHARED_DATA put in, is the folder the command
    reads (its refusal names it): the help had read "($AION_SHARED_DATA, else
    ../shared/data/lincoln)", as if the variable named the dataset's own folder."""
    shared = tmp_path / "data"
    monkeypatch.setenv("AION_SHARED_DATA", str(shared))
    runner = CliRunner()
    helped = " ".join(runner.invoke(cli, ["evaluate", command, "--help"]).stdout.split())
    default = re.search(r"--data DIR .*?\[default: \((\S+), else", helped)
    assert default is not None, helped
    said = Path(default.group(1).replace("$AION_SHARED_DATA", str(shared)))
    result = runner.invoke(cli, ["evaluate", command])
    assert result.exit_code == 2
    assert f"folder not found: {said}\n" in result.stderr
    assert said == shared / folder
