"""``aion plan`` on a map whose scene graph's places hold no detection printed a "temporal" plan
equal to the "distance only" one, its cost its length, without a word on why: the real
leg_tracker recording built with ``--derive-graph`` keeps all its detections on hash cells (its
places were never stable for 30 s in a half-second log), so every place forecasts no flow and
the temporal plan has nothing to avoid. It now says so; a map whose places hold people (the
office log) does not."""

from __future__ import annotations

import json
from pathlib import Path

from tests.cli.conftest import Office, run, run_json
from tests.shared_data import real

SAID = "places holds a detection"


def test_a_plan_over_places_without_detections_says_it_plans_by_distance(
    tmp_path: Path,
) -> None:
    log = real("logs", "leg_tracker", "positive_2_extracted.bag")
    out = tmp_path / "legs.aion"
    built = run_json("build", log, "--map-frame", "right_laser", "--derive-graph", "-o", out,
                     "--workers", "1", "--format", "json")  # fmt: skip
    assert built["nodes"] > 1, built
    assert built["nodes_with_flow"] == 0, built
    used = built["detections"]["used"]
    assert used > 0
    result = run("plan", out, "--from", "p0", "--to", f"p{built['nodes'] - 1}",
                 "--time", "2015-03-16 03:16", "--format", "json")  # fmt: skip
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split())
    assert (
        f"none of the scene graph's {built['nodes']:,} places holds a detection (the map's "
        f"{used:,} lie on hash cells" in said
    ), said
    assert "it plans by distance alone" in said, said
    # what the note says: the temporal plan's cost is its length, as the distance-only one's
    plan = json.loads(result.stdout)
    for key in ("temporal", "distance_only"):
        assert abs(plan[key]["cost"] - plan[key]["length_m"]) < 1e-9, plan[key]
    assert plan["temporal"]["length_m"] == plan["distance_only"]["length_m"]


def test_a_plan_over_places_with_people_says_nothing_of_it(office: Office) -> None:
    result = run("plan", office.map, "--from", "p0", "--to", "p2", "--time", "2026-01-12 08:40")
    assert result.exit_code == 0, result.stderr
    assert office.build["nodes_with_flow"] > 0
    assert SAID not in " ".join(result.stderr.split())


def test_map_plan_carries_the_note_as_aion_plan_prints_it(tmp_path: Path) -> None:
    import aion_cli as aion

    log = real("logs", "leg_tracker", "positive_2_extracted.bag")
    out = tmp_path / "legs.aion"
    run_json("build", log, "--map-frame", "right_laser", "--derive-graph", "-o", out,
             "--workers", "1", "--format", "json")  # fmt: skip
    plan = aion.Map.load(out).plan("p0", "p1", time="2015-03-16 03:16")
    assert [n for n in plan.notes if SAID in n] == [
        n for n in run("plan", out, "--from", "p0", "--to", "p1", "--time",
                       "2015-03-16 03:16").stderr.splitlines() if SAID in n
    ]  # fmt: skip
    assert any("it plans by distance alone" in n for n in plan.notes)
    best = aion.Map.load(out).plan("p0", "p1", leave=("2015-03-16 03:10", "2015-03-16 03:20"))
    assert any(SAID in n for n in best.notes)


def test_an_exported_path_over_such_places_says_so_too(tmp_path: Path) -> None:
    """``aion export --path-from/--path-to`` draws the temporal plan as plan makes it: over
    those places it is the shortest by distance, and the export says so (Map.export's notes
    too); with --historical it already said the path is the shortest by distance."""
    import aion_cli as aion

    log = real("logs", "leg_tracker", "positive_2_extracted.bag")
    out = tmp_path / "legs.aion"
    run_json("build", log, "--map-frame", "right_laser", "--derive-graph", "-o", out,
             "--workers", "1", "--format", "json")  # fmt: skip
    at = ("--time", "2015-03-16 03:16", "--path-from", "p0", "--path-to", "p1")
    result = run("export", out, *at, "-o", tmp_path / "scene")
    assert result.exit_code == 0, result.stderr
    lines = [n for n in result.stderr.splitlines() if SAID in n]
    assert len(lines) == 1, result.stderr
    assert lines[0].endswith("the path drawn has no flow to avoid: it is the shortest by distance")
    files = aion.Map.load(out).export(tmp_path / "api", time="2015-03-16 03:16", path=("p0", "p1"))
    assert [n for n in files.notes if SAID in n] == lines
    historical = run("export", out, "--historical", *at[2:], "-o", tmp_path / "hist")
    assert historical.exit_code == 0, historical.stderr
    assert SAID not in historical.stderr  # its own note says it
    assert "the path drawn is the shortest by distance" in " ".join(historical.stderr.split())
