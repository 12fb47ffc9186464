"""``predict --layer places`` on a map of hash cells only (built without a scene graph) is an
error (exit 2), as ``--layer rooms`` is on a graph without rooms: an empty table (exit 0)
would read as "nobody walks there"."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import Office, assert_one_line_error, run, run_json
from tests.cli.logdata import write_office_log

AT = "2026-11-23 08:30"
SERIES = ("--from", "2026-11-23 08:00", "--to", "2026-11-23 09:00")


@pytest.fixture(scope="module")
def cells_only(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A map built without a scene graph: hash cells, no places."""
    folder = tmp_path_factory.mktemp("cells")
    write_office_log(folder / "bare.mcap", graph=False)
    out = folder / "bare.aion"
    assert run("build", folder / "bare.mcap", "-o", out, "-q").exit_code == 0
    return out


@pytest.mark.parametrize("fmt", ["table", "json", "csv"])
@pytest.mark.parametrize("when", [("--time", AT), SERIES, ("--historical",)])
def test_places_of_a_map_without_places(cells_only: Path, fmt: str, when: tuple[str, ...]) -> None:
    assert run_json("predict", cells_only, *when, "--format", "json")["entries"]
    result = run("predict", cells_only, *when, "--layer", "places", "--format", fmt)
    assert result.exit_code == 2, result.stdout
    assert_one_line_error(result.stderr, "no places")
    assert result.stdout == ""


def test_places_near_a_point_of_a_map_without_places(cells_only: Path) -> None:
    result = run("predict", cells_only, "--time", AT, "--layer", "places", "--at", "1,1")
    assert result.exit_code == 2, result.stdout
    assert_one_line_error(result.stderr, "no places")


def test_cells_of_a_map_whose_cells_all_bound_stay_an_empty_answer(office: Office) -> None:
    """Cells bind to places (a healthy map may have none unbound): that stays an empty list."""
    assert run_json("predict", office.map, "--time", AT, "--layer", "places", "--format", "json")[
        "entries"
    ]
    assert run_json("predict", office.map, "--time", AT, "--layer", "cells", "--format", "json")[
        "entries"
    ] == []


def test_the_api_raises_the_same_error(cells_only: Path) -> None:
    import aion_cli as aion

    m = aion.Map.load(cells_only)
    with pytest.raises(aion.InputError, match="no places"):
        m.predict(AT, tz="UTC", layer="places")
    with pytest.raises(aion.InputError, match="no places"):
        m.predict_series(SERIES[1], SERIES[3], "1h", tz="UTC", layer="places")
