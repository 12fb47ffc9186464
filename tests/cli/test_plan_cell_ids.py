"""A hash cell's id as ``predict`` prints it (``c4611686018427387904``) given to ``plan
--from/--to``, ``export --path-from/--path-to`` or ``Map.plan``: paths run between places, so
it is an error that says so and how to give the cell instead (its position), with a hint.
Before, it read as node category ``c`` with an index beyond 56 bits: ``error: node index too
large in 'c46...'`` and no hint line."""

from __future__ import annotations

from pathlib import Path

import pytest

import aion_cli as aion
from aion_cli.errors import InputError
from tests.cli.conftest import Office, assert_one_line_error, run

CELL = "c4611688217430720504"  # the form of a hash cell's id in predict's table
T = "2026-01-12 08:40"


def test_plan_and_export_refuse_a_cell_id_saying_what_it_is(office: Office, tmp_path: Path) -> None:
    for args in (
        ("plan", office.map, "--from", CELL, "--to", "p2", "--time", T),
        ("plan", office.map, "--from", "p2", "--to", CELL, "--time", T),
        ("export", office.map, "--time", T, "--path-from", CELL, "--path-to", "p2",
         "-o", tmp_path / "out"),
    ):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, f"{CELL} is a hash cell")
        assert f"hint: give its position as x,y (aion predict MAP --node {CELL}" in result.stderr
    with pytest.raises(InputError, match="is a hash cell"):
        aion.Map.load(office.map).plan(CELL, "p2", time=T)


def test_a_node_index_beyond_56_bits_has_a_hint() -> None:
    """(A map whose graph names rooms lists them instead; without, this error was hintless.)"""
    from aion_cli.engine.node_ids import parse_node_id

    with pytest.raises(InputError, match="node index too large") as caught:
        parse_node_id("p99999999999999999999")
    assert caught.value.hint
