"""``aion evaluate atc --data DIR`` with a folder of some of the ATC files: a protocol with
nothing to test printed an empty table and exit 0 (success for no result), one with nothing to
train on failed inside (``internal error: ValueError: zero-size array ...``). Both are now one
``error:`` line naming the files the folder holds, with the protocol's hours as the hint."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run

T9 = 1_351_036_800  # 2012-10-24 09:00 JST


def _atc(folder: Path, hour: int, split: str) -> None:
    t0 = T9 + (hour - 9) * 3600
    rows = [f"{t0 + 60 + i}.0,{7 + hour},{i * 0.5:.1f},1.0,0.5,0.0" for i in range(30)]
    (folder / f"atc-1024-{hour}_{split}.csv").write_text("\n".join(rows) + "\n")


@pytest.mark.parametrize(
    ("files", "protocol", "fragment"),
    [
        ([(9, "train"), (9, "test")], "chronological", "no test hour for the chronological"),
        ([(18, "train"), (18, "test")], "chronological", "no training detections"),
        ([(9, "train")], "random", "no test hour for the random protocol"),
        ([(9, "test")], "random", "no training detections for the random protocol"),
    ],
)
def test_a_folder_without_what_the_protocol_needs_is_an_error(
    tmp_path: Path, files: list[tuple[int, str]], protocol: str, fragment: str
) -> None:
    for hour, split in files:
        _atc(tmp_path, hour, split)
    result = run("evaluate", "atc", "--data", tmp_path, "--protocol", protocol, "-q")
    assert result.exit_code == 2, (result.stdout, result.stderr)
    assert_one_line_error(result.stderr, fragment)
    assert "hint: the " in result.stderr
    assert result.stdout == ""


def test_a_folder_with_both_still_evaluates(tmp_path: Path) -> None:
    for split in ("train", "test"):
        _atc(tmp_path, 9, split)
    result = run("evaluate", "atc", "--data", tmp_path, "--format", "json", "-q")
    assert result.exit_code == 0, result.stderr
    assert '"per_hour"' in result.stdout


def test_the_progress_counts_the_detections_the_table_scores(tmp_path: Path) -> None:
    """A test row of speed 0 has no heading and is not scored: the progress said 'scoring
    9:00 (30 detections)' above a table of 29 (real data: hour 20, 1,332 and 1,331)."""
    from aion_cli.evaluation.atc import run_atc

    for split in ("train", "test"):
        _atc(tmp_path, 9, split)
    test = tmp_path / "atc-1024-9_test.csv"
    rows = test.read_text().splitlines()
    rows[5] = ",".join([*rows[5].split(",")[:4], "0.0", "0.0"])  # standing: no heading
    test.write_text("\n".join(rows) + "\n")
    said: list[str] = []
    result = run_atc(tmp_path, "random", progress=said.append)
    assert "scoring 9:00 (30 detections, 29 of them with a heading)" in said
    assert {row["detections"] for row in result.rows} == {29}


@pytest.mark.parametrize(
    ("protocol", "files", "untrained", "said"),
    [
        ("random", [(9, "train"), (9, "test"), (10, "test")], [10],
         "10:00 has no training data (atc-1024-10_train.csv not in the folder): its test "
         "people are scored by models trained on the other hours only"),
        ("chronological", [(9, "train"), (9, "test"), (10, "test"), (17, "test")], [10],
         "10:00 has no training file (atc-1024-10_train.csv not in the folder): trained on "
         "its _test file alone"),
        ("random", [(9, "train"), (9, "test"), (10, "train"), (10, "test")], [], None),
    ],
    ids=["random", "chronological", "all-trained"],
)
def test_an_hour_without_training_data_is_named(
    tmp_path: Path, protocol: str, files: list[tuple[int, str]], untrained: list[int],
    said: str | None,
) -> None:
    """The real data has no atc-1024-12_train.csv: hour 12 was scored (random) as any other,
    its row in --per-hour and JSON with no word that no model saw anyone of that hour."""
    for hour, split in files:
        _atc(tmp_path, hour, split)
    result = run("evaluate", "atc", "--data", tmp_path, "--protocol", protocol, "--per-hour")
    assert result.exit_code == 0, result.stderr
    stderr = " ".join(result.stderr.split())
    if said:
        assert said in stderr
    else:
        assert "no training" not in stderr
    doc = run("evaluate", "atc", "--data", tmp_path, "--protocol", protocol, "--format",
              "json", "-q")
    payload = json.loads(doc.stdout)
    assert payload["hours_without_training"] == untrained
    assert len(payload["notes"]) == len(untrained)
    if said:
        assert payload["notes"][0].startswith(said)
