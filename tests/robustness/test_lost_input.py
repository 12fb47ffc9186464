"""Input lost to the read limits is said once, clearly, and never reported as a success.

A chunk or message over ``--max-chunk-mb`` / ``--max-message-mb`` is skipped with a warning
(``test_bombs.py``). Here: a log whose every chunk is skipped is an error for ``aion info`` too
(it was a table of zero messages, exit 0), the error names one reason and counts the rest
instead of joining 56 of them into one line; hundreds of skipped messages print a few warnings
and one line counting the rest; and a build whose every scene graph was skipped says the map
has no places.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from aion_cli.cli.console import warn_each, warning_shape
from aion_cli.formats.limits import CHUNK_ENV, MESSAGE_ENV
from tests.cli.conftest import SAMPLE
from tests.robustness.conftest import assert_one_error, run


@pytest.fixture(autouse=True)
def _limits_restored(monkeypatch: pytest.MonkeyPatch) -> None:
    """``aion --max-chunk-mb`` sets the environment of the process it runs in (so that worker
    processes inherit it); the in-process runs here get it restored after each test."""
    for name in (CHUNK_ENV, MESSAGE_ENV):
        monkeypatch.setenv(name, "1")  # recorded: the original state comes back at teardown
        monkeypatch.delenv(name)


def _sample_chunks() -> int:
    """The sample's chunks, as the MCAP library's summary counts them."""
    from mcap.reader import make_reader

    with open(SAMPLE, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert summary.statistics is not None
    return int(summary.statistics.chunk_count)


def test_info_of_a_log_whose_every_chunk_is_skipped_is_an_error() -> None:
    result = run("--max-chunk-mb", "0.001", "info", SAMPLE)
    assert result.exit_code == 2, result.stderr
    error = next(line for line in result.stderr.splitlines() if line.startswith("error:"))
    # the first chunk's reason, and the others counted, not joined
    assert "chunk at byte 33 skipped" in error
    assert "over the 0.001 MiB limit per chunk" in error
    assert f"and {_sample_chunks() - 1} more warnings like it" in error
    assert error.count("skipped") == 1
    assert "none of its messages could be read" in result.stderr
    assert result.stdout == ""


def test_build_of_a_log_whose_every_chunk_is_skipped_is_the_same_error(tmp_path: Path) -> None:
    out = tmp_path / "x.aion"
    result = run("--max-chunk-mb", "0.001", "build", SAMPLE, "-o", out)
    assert result.exit_code == 2
    assert f"and {_sample_chunks() - 1} more warnings like it" in result.stderr
    assert not out.exists()


def test_info_of_an_empty_recording_is_still_a_description(tmp_path: Path) -> None:
    """An MCAP with a header and footer and nothing between is a well-formed recording of no
    messages: ``info`` describes it (nothing was lost), ``build`` refuses it."""
    from mcap.writer import Writer

    path = tmp_path / "empty.mcap"
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        writer.finish()
    described = run("info", path)
    assert described.exit_code == 0, described.stderr
    assert "messages: 0" in described.stdout
    refused = run("build", path, "-o", tmp_path / "x.aion")
    assert refused.exit_code == 2
    assert_one_error(refused.stderr, f"{path}: no messages")


def test_skipped_graphs_are_counted_not_listed_and_the_missing_places_said(
    tmp_path: Path,
) -> None:
    """Every scene graph of the sample (510 messages of 26-87 KiB) over a 0.01 MiB cap: three
    warnings of that shape, one line counting the other 507, and a warning that the map has
    no places; the JSON report keeps every warning."""
    out = tmp_path / "x.aion"
    table = run("--max-message-mb", "0.01", "build", SAMPLE, "-o", out)
    assert table.exit_code == 0, table.stderr
    warnings = [line for line in table.stderr.splitlines() if line.startswith("warning:")]
    skipped = [line for line in warnings if line.startswith("warning: office.mcap: a message on")]
    assert len(skipped) == 3
    assert any(line.startswith("warning: 507 more like 'office.mcap: a message on") for line in
               warnings)
    assert any("no scene graph of /hydra/backend/dsg could be used" in line and
               "hash cells only, no places" in line for line in warnings)
    as_json = run("--max-message-mb", "0.01", "build", SAMPLE, "-o", out, "--format", "json")
    report = json.loads(as_json.stdout)
    assert report["nodes"] == 0
    assert sum("a message on /hydra/backend/dsg" in w for w in report["warnings"]) == 510


def test_a_build_with_its_graphs_makes_no_such_warning(tmp_path: Path) -> None:
    result = run("build", SAMPLE, "-o", tmp_path / "x.aion")
    assert result.exit_code == 0, result.stderr
    assert "no scene graph" not in result.stderr
    assert "more like" not in result.stderr


@pytest.mark.parametrize(
    ("a", "b", "same"),
    [
        ("x.mcap: chunk at byte 33 skipped: 1 MiB", "x.mcap: chunk at byte 84000 skipped: 1.1 MiB",
         True),
        ("a message at 2026-01-05T00:00:00.000000Z skipped",
         "a message at 2026-01-09T19:04:00.000000Z skipped", True),
        ("x.mcap: chunk at byte 33 skipped", "y.mcap: chunk at byte 33 skipped", False),
        ("/tf: 3 undecodable", "/tf_static: 3 undecodable", False),
    ],
)
def test_warning_shapes_ignore_only_numbers_and_times(a: str, b: str, same: bool) -> None:
    assert (warning_shape(a) == warning_shape(b)) is same


def test_warn_each_prints_a_few_of_each_shape_in_order(capsys: pytest.CaptureFixture[str]) -> None:
    messages = [f"chunk at byte {k} skipped" for k in range(10)] + ["the map has no places"]
    warn_each(messages, limit=2)
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        "warning: chunk at byte 0 skipped",
        "warning: chunk at byte 1 skipped",
        "warning: the map has no places",
        "warning: 8 more like 'chunk at byte 0 skipped' (--format json lists every one)",
    ]
