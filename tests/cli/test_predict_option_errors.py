"""``predict`` options that did nothing or did not say which option was wrong:
``--historical --tz X`` was taken and changed nothing without a word (the historical flows
have no time: now a note says so, and the answer is the same);
``--from bad`` said "cannot read the time 'bad'" without naming ``--from``."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import Office, assert_one_line_error, run, run_json


def test_historical_notes_that_a_zone_changes_nothing(office: Office) -> None:
    zoned = run("predict", office.map, "--historical", "--tz", "Asia/Tokyo", "--format", "json")
    plain = run("predict", office.map, "--historical", "--format", "json")
    assert zoned.exit_code == plain.exit_code == 0, zoned.stderr
    assert zoned.stdout == plain.stdout
    assert "--tz changes nothing with --historical" in zoned.stderr
    assert "--tz" not in plain.stderr


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--from", "bad", "--to", "12:00"], "--from 'bad': cannot read the time"),
        (["--from", "10:00", "--to", "worse"], "--to 'worse': cannot read the time"),
        (["--time", "bad"], "--time 'bad': cannot read the time"),
    ],
)
def test_an_unreadable_time_names_its_option(
    office: Office, args: list[str], named: str
) -> None:
    out = run("predict", office.map, *args)
    assert out.exit_code == 2
    assert_one_line_error(out.stderr, named)


@pytest.mark.parametrize(("layer", "kind", "said"), [("cells", "node", "a place"),
                                                     ("places", "cell", "a hash cell")])
def test_an_entry_of_the_other_layer_is_not_called_missing(
    sample_map: Path, layer: str, kind: str, said: str
) -> None:
    """``--node p1 --layer cells`` said "node p1 is not in the map" of a place predict lists
    without --layer: the user checked an id that was right. It is on the other layer."""
    listed = run_json("predict", sample_map, "--historical", "--format", "json")["entries"]
    entry = next(e["id"] for e in listed if e["kind"] == kind)  # in the map: predict lists it
    out = run("predict", sample_map, "--historical", "--node", entry, "--layer", layer)
    assert out.exit_code == 2
    assert_one_line_error(out.stderr, f"{entry} is {said} of the map, not on --layer {layer}")
    assert "not in the map" not in out.stderr


def test_several_missing_nodes_are_named_in_the_plural(office: Office) -> None:
    """``--node p98 --node p99`` (neither in the map) said "node p98, p99 is not in the map";
    one missing node keeps the singular."""
    two = run("predict", office.map, "--historical", "--node", "p98", "--node", "p99")
    assert two.exit_code == 2
    assert_one_line_error(two.stderr, "nodes p98, p99 are not in the map")
    one = run("predict", office.map, "--historical", "--node", "p98", "--node", "p1")
    assert one.exit_code == 2
    assert_one_line_error(one.stderr, "node p98 is not in the map")
