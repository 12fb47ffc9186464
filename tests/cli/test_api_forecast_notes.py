"""What a forecast at a time cannot say (:mod:`aion_cli.forecast_notes`: every entry at its
static rate, a time a week or more after the map's data, an hour no log observed) ``aion
predict`` and ``aion plan`` print beside the time they used; a script asking ``Map.predict``,
``Map.predict_series`` or ``Map.plan`` the same got none of it (only ``hour_observed``), so a
forecast ten years past a half-hour map looked as measured as any. The results carry the same
notes in ``notes``."""

from __future__ import annotations

from pathlib import Path

import pytest

import aion_cli as aion
from tests.cli.conftest import Office, run

LATER = "2026-12-10 03:00"  # 17 days after the office log (2026-11-23 08:00-08:20), at night


def _notes(stderr: str) -> list[str]:
    """The notes the command printed after the line naming its time (wrapped lines joined)."""
    text = " ".join(stderr.split())
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    assert lines[0].startswith(("time: ", "departure: ", "from: ", "best departure: ")), stderr
    first = " ".join(lines[0].split())
    return [text[len(first):].strip()] if text != first else []


@pytest.fixture(scope="module")
def m(office: Office) -> aion.Map:
    return aion.Map.load(office.map)


def test_a_prediction_carries_the_notes_the_command_prints(office: Office, m: aion.Map) -> None:
    table = m.predict(LATER, tz="UTC")
    cli = run("predict", office.map, "--time", LATER, "--tz", "UTC", "--format", "json")
    assert cli.exit_code == 0, cli.stderr
    assert table.notes, "a forecast 17 days after a 20-minute map, at an unobserved hour"
    assert _notes(cli.stderr) == [" ".join(table.notes)]
    assert any("after the map's data" in n for n in table.notes)
    assert any("no log observed 03:00-04:00" in n for n in table.notes)
    assert m.predict(historical=True).notes == ()  # what was observed: nothing to caution
    # the JSON (Table.to_dict) is the command's, without them
    assert "notes" not in table.to_dict()


def test_a_series_and_plans_carry_them_too(office: Office, m: aion.Map) -> None:
    series = m.predict_series(LATER, "2026-12-10 09:00", "3h", tz="UTC")
    cli = run("predict", office.map, "--from", LATER, "--to", "2026-12-10 09:00", "--step",
              "3h", "--tz", "UTC", "--format", "json")
    assert _notes(cli.stderr) == [" ".join(series.notes)]
    assert any("of the 3 times fall in hours no log observed" in n for n in series.notes)
    plan = m.plan("p0", "p2", time=LATER, tz="UTC")
    cli = run("plan", office.map, "--from", "p0", "--to", "p2", "--time", LATER, "--tz", "UTC",
              "--format", "json")
    assert _notes(cli.stderr) == [" ".join(plan.notes)]
    best = m.plan("p0", "p2", leave=(LATER, "2026-12-10 05:00"), step="1h", tz="UTC")
    cli = run("plan", office.map, "--from", "p0", "--to", "p2", "--leave",
              f"{LATER}..2026-12-10 05:00", "--step", "1h", "--tz", "UTC", "--format", "json")
    assert _notes(cli.stderr) == [" ".join(best.notes)]
    assert any("of the 3 departures fall in hours" in n for n in best.notes)


def test_a_wall_clock_time_a_clock_change_skips_is_noted(office: Office, m: aion.Map) -> None:
    """"2026-03-29 02:30" does not exist in Madrid (clocks go from 02:00 to 03:00): aion
    predict says which instant it read it as, before the forecast's notes; Map.predict and
    Map.plan answered for that instant without a word. Their notes now begin with it."""
    gap = "2026-03-29 02:30"
    table = m.predict(gap, tz="Europe/Madrid")
    cli = run("predict", office.map, "--time", gap, "--tz", "Europe/Madrid", "--format", "json")
    assert _notes(cli.stderr) == [" ".join(table.notes)]
    assert "02:30" in table.notes[0]
    assert table.time == "2026-03-29 03:30:00+02:00"  # the instant it was read as
    plan = m.plan("p0", "p2", time=gap, tz="Europe/Madrid")
    cli = run("plan", office.map, "--from", "p0", "--to", "p2", "--time", gap, "--tz",
              "Europe/Madrid", "--format", "json")
    assert _notes(cli.stderr) == [" ".join(plan.notes)]
    assert plan.notes[0] == table.notes[0]
    series = m.predict_series(gap, "2026-03-29 06:30", "2h", tz="Europe/Madrid")
    cli = run("predict", office.map, "--from", gap, "--to", "2026-03-29 06:30", "--step", "2h",
              "--tz", "Europe/Madrid", "--format", "json")
    assert _notes(cli.stderr) == [" ".join(series.notes)]
    assert series.notes[0] == table.notes[0]


def test_query_errors_and_notes_name_the_query_keywords(tmp_path: Path) -> None:
    """Map.predict's hint on a map of hash cells only said "pick one by position with --at
    X,Y, or list ids with --top 10", and a static-only model's note (now in Table.notes)
    "its flows are those of --historical": options of aion predict; the keywords are at, top
    and historical."""
    import numpy as np

    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch

    mapper = Mapper(ModelConfig.from_dict({"families": ["static"]}))
    t0 = 1_767_607_200 * 10**9
    t = t0 + np.arange(0, 3600, 10) * 10**9
    mapper.set_fixed_sensor(int(t[0]), int(t[-1]))
    xyz = np.c_[np.linspace(0, 5, len(t)), np.zeros(len(t)), np.zeros(len(t))]
    mapper.add_detections(DetectionBatch.from_arrays(t, xyz, np.zeros(len(t)), np.ones(len(t))))
    cells = aion.Map.from_state(mapper.state, timezone="UTC")
    with pytest.raises(aion.InputError) as caught:
        cells.predict("2026-01-05 10:30", nodes=["p1"])
    assert caught.value.hint is not None
    assert caught.value.hint.endswith("pick one by position with at=X,Y, or list ids with top=10")
    with pytest.raises(aion.InputError) as caught:  # a point given as a node id
        cells.predict("2026-01-05 10:30", nodes=["4,0"])
    assert caught.value.message.startswith("nodes= takes ids and room names; ")
    assert caught.value.hint is not None
    assert caught.value.hint.startswith('at="4,0" answers for the entry nearest to it')
    saved = aion.Map.load(cells.save(tmp_path / "static.aion"))
    notes = saved.predict("2026-01-05 10:30").notes
    assert any("its flows are those of historical=True" in n for n in notes), notes
    assert not [n for n in notes if "--" in n], notes


def test_a_plans_notes_are_a_tuple_as_a_tables(m: aion.Map) -> None:
    """``Plan.notes`` was a list where ``Table.notes`` and a series' notes are tuples: a plan's
    and a table's notes at one time did not compare equal."""
    table = m.predict(LATER, tz="UTC")
    plan = m.plan("p0", "p2", time=LATER, tz="UTC")
    assert len(table.notes) >= 2  # after the map's data, an hour no log observed
    assert isinstance(plan.notes, tuple)  # before: a list, never equal to the table's tuple
    # the same notes, a plan's at an hour no log observed saying its costs come from there
    costs = "; the plan's costs come from these extrapolated flows"
    assert plan.notes == (*table.notes[:-1], table.notes[-1] + costs)
    best = m.plan("p0", "p2", leave=(LATER, "2026-12-10 05:00"), step="1h", tz="UTC")
    assert isinstance(best.notes, tuple)
    assert isinstance(best.distance_only.notes, tuple)
