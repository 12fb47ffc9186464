"""``aion predict --at X,Y``: which entry a point stands for, said."""

from __future__ import annotations

import math

from tests.cli.conftest import Office, run, run_json

AT = "2026-11-23 08:30"


def test_a_point_says_which_entry_it_stands_for_and_how_far(office: Office) -> None:
    """--at X,Y answered with the nearest entry's row and no word that it was the nearest, nor
    how far (a point 4 m from any place read as that place's own): a note names the entry
    and its distance, the one the row's own position gives, in a series too; -q leaves it
    out."""
    (row,) = run_json("predict", office.map, "--time", AT, "--at", "5.8,0.3",
                      "--format", "json")["entries"]
    away = math.dist((row["x"], row["y"]), (5.8, 0.3))  # horizontal: a point without z
    said = run("predict", office.map, "--time", AT, "--at", "5.8,0.3").stderr
    assert f"--at 5.8,0.3: the entry nearest the point is {row['id']}, {away:.2f} m from it" in (
        " ".join(said.split())
    ), said
    series = run("predict", office.map, "--from", AT, "--to", AT, "--at", "5.8,0.3",
                 "--format", "csv").stderr
    assert f"the entry nearest the point is {row['id']}, {away:.2f} m" in " ".join(series.split())
    quiet = run("predict", office.map, "--time", AT, "--at", "5.8,0.3", "-q")
    assert quiet.exit_code == 0
    assert "nearest" not in quiet.stderr


def test_a_point_given_to_node_points_to_at(office: Office) -> None:
    """``--node 5.8,0.3`` (coordinates, as ``plan --from`` takes them) said "not a node id"
    with a hint about ids only; now it names --at with the same point, which answers."""
    from tests.cli.conftest import assert_one_line_error

    for args in (["--time", AT], ["--from", AT, "--to", AT]):
        result = run("predict", office.map, *args, "--node", "p1", "--node", "5.8,0.3")
        assert result.exit_code == 2
        assert_one_line_error(result.stderr, "'5.8,0.3' is a point")
        assert "hint: --at 5.8,0.3 " in result.stderr
    answered = run_json("predict", office.map, "--time", AT, "--at", "5.8,0.3", "--format", "json")
    assert len(answered["entries"]) == 1


def test_a_mistyped_point_is_refused_before_the_map_is_read(office: Office) -> None:
    """``--at "2026-01-05 10:30"`` (a time where a point goes) was refused only after the map
    was read and queried: 6.4 s on a map of 10^5 entries. It is checked first now: even a map
    that does not exist is not reached."""
    result = run("predict", office.map.with_name("missing.aion"), "--at", "2026-01-05 10:30")
    assert result.exit_code == 2
    assert "--at expects coordinates x,y[,z], got '2026-01-05 10:30'" in result.stderr
    assert "not found" not in result.stderr
