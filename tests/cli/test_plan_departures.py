"""``aion plan --leave START..END [--step]``: every departure is the plan ``--time`` makes
then, and the one kept is the least temporal cost (the earliest of equal ones)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.cli.conftest import Office, assert_one_line_error, figure_texts, run, run_json

SPAN = "2026-01-12 06:00..2026-01-12 12:00"


def _plan(map_path: Path, *extra: str, ends: tuple[str, str] = ("p103", "p2")) -> Any:
    return run_json(
        "plan", map_path, "--from", ends[0], "--to", ends[1], "--tz", "UTC", "--format", "json",
        *extra,
    )


def test_each_departure_is_the_plan_at_that_time_and_the_least_cost_is_kept(
    sample_map: Path,
) -> None:
    doc = _plan(sample_map, "--leave", SPAN, "--step", "1h")
    rows = doc["departures"]
    assert [r["depart"][11:16] for r in rows] == [f"{h:02d}:00" for h in range(6, 13)]
    costs = [r["cost"] for r in rows]
    assert len(set(costs)) > 1  # the routine makes the hours differ
    best = min(range(len(rows)), key=lambda k: (costs[k], k))
    assert [r["best"] for r in rows] == [k == best for k in range(len(rows))]
    assert doc["depart"] == rows[best]["depart"]
    for row in rows:  # every row is what --time says at that departure
        single = _plan(sample_map, "--time", row["depart"])
        assert single["temporal"]["cost"] == row["cost"]
        assert single["temporal"]["length_m"] == row["length_m"]
        assert single["distance_only"]["cost"] == row["distance_only_cost"]
    chosen = _plan(sample_map, "--time", rows[best]["depart"])
    assert doc["temporal"] == chosen["temporal"]


def test_the_table_marks_the_best_departure(sample_map: Path) -> None:
    result = run(
        "plan", sample_map, "--from", "p103", "--to", "p2", "--tz", "UTC", "--leave", SPAN,
        "--step", "2h",
    )
    assert result.exit_code == 0, result.stderr
    assert "departures" in result.stdout
    assert result.stdout.count("best") == 1
    assert "best departure: 2026-01-12" in result.stderr


def test_equal_costs_keep_the_earliest(office: Office) -> None:
    """The 20-minute office map forecasts static rates: every departure costs the same."""
    doc = _plan(
        office.map, "--leave", "2026-11-23 08:00..2026-11-23 09:00", "--step", "20m",
        ends=("p0", "p2"),
    )
    costs = {r["cost"] for r in doc["departures"]}
    assert len(costs) == 1
    assert doc["departures"][0]["best"]
    assert doc["depart"].startswith("2026-11-23 08:00")


def test_departures_all_of_one_cost_are_said_to_be_alike(office: Office, sample_map: Path) -> None:
    """Stop 67's audit: a static map (every departure 6.3) printed "best departure: 07:00" and
    marked 07:00 "best", as if leaving then were quieter. Now a note says every departure
    costs the same and the earliest is shown; a map whose hours differ has no such note."""
    span = ("--leave", "2026-11-23 08:00..2026-11-23 09:00", "--step", "20m")
    table = run("plan", office.map, "--from", "p0", "--to", "p2", "--tz", "UTC", *span)
    assert table.exit_code == 0, table.stderr
    cost = _plan(office.map, *span, ends=("p0", "p2"))["departures"][0]["cost"]
    said = " ".join(table.stderr.split())
    assert (
        f"every departure costs the same ({cost:.1f}): the map forecasts no quieter time "
        "to leave among them, so the earliest is shown"
    ) in said
    varied = run("plan", sample_map, "--from", "p103", "--to", "p2", "--tz", "UTC", "--leave",
                 SPAN, "--step", "2h")  # fmt: skip
    assert varied.exit_code == 0, varied.stderr
    assert "costs the same" not in varied.stderr
    quiet = run("plan", office.map, "--from", "p0", "--to", "p2", "--tz", "UTC", *span, "-q")
    assert "costs the same" not in quiet.stderr


def test_costs_within_a_tenth_of_a_percent_are_one_cost() -> None:
    """hG's map: 07:00 cost 8.000133 and 07:30 8.000100, both shown as 8.0; 07:30 was marked
    best, against "the earliest of equal ones". A cost truly lower by more than 0.1 % wins."""
    from aion_cli.routes import best_departure

    assert best_departure([8.000133, 8.000100, 8.2]) == 0
    assert best_departure([8.2, 8.000133, 8.000100]) == 1
    assert best_departure([8.02, 8.0]) == 1  # 0.25 % dearer: the later one is the answer
    assert best_departure([5.0]) == 0
    # equal costs (a static map's): an hour the map observed before an extrapolated one
    assert best_departure([8.0, 8.0, 8.0], [False, True, True]) == 1
    assert best_departure([8.0, 8.0], [False, False]) == 0  # none observed: the earliest
    assert best_departure([8.0, 7.0], [True, False]) == 1  # a truly lower cost still wins
    assert best_departure([8.0, 8.0], [None, None]) == 0  # a map that lists no hours


def test_departures_at_hours_no_log_observed_are_marked(office: Office) -> None:
    """The office log observed 08:00-08:20 (UTC) only: leaving at 07:00 or 09:00 plans on
    extrapolated flows, which the JSON, the table and a note say."""
    span = ("--leave", "2026-11-23 07:00..2026-11-23 09:00", "--step", "1h")
    doc = _plan(office.map, *span, ends=("p0", "p2"))
    assert [r["hour_observed"] for r in doc["departures"]] == [False, True, False]
    table = run("plan", office.map, "--from", "p0", "--to", "p2", "--tz", "UTC", *span)
    assert table.exit_code == 0, table.stderr
    assert table.stdout.count("extrapolated") == 2
    assert (
        "2 of the 3 departures fall in hours no log observed on any day (07:00-08:00, "
        "09:00-10:00 UTC; the map observed 08:00-09:00)"
    ) in " ".join(table.stderr.split())


def test_a_plan_at_an_hour_no_log_observed_says_its_costs_are_extrapolated(
    office: Office,
) -> None:
    """Before: ``plan --time 07:00`` on the office map (observed 08:00-08:20 UTC) printed its
    table as at 08:05, its JSON had no hour_observed, and only predict's note ("the forecast at
    this hour is extrapolated") hinted that the costs were. Now the title, the JSON and a note
    say it; the best departure of --leave likewise; not at an observed hour."""
    at = ("--from", "p0", "--to", "p3", "--tz", "UTC")
    early = run("plan", office.map, *at, "--time", "2026-11-30 07:00")
    assert early.exit_code == 0, early.stderr
    assert "departing 2026-11-30 07:00:00+00:00 (extrapolated: an hour no log observed)" in (
        " ".join(early.stdout.split()))
    said = " ".join(early.stderr.split())
    assert "not measured: every entry at its static rate" in said
    assert "quiet ones); the plan's costs come from these extrapolated flows" in said
    assert _plan(office.map, "--time", "2026-11-30 07:00", ends=("p0", "p3"))[
        "hour_observed"] is False
    seen = run("plan", office.map, *at, "--time", "2026-11-30 08:05")
    assert "extrapolated" not in seen.stdout + seen.stderr
    assert _plan(office.map, "--time", "2026-11-30 08:05", ends=("p0", "p3"))["hour_observed"]
    leave = ("--leave", "2026-11-30 07:00..2026-11-30 07:30", "--step", "30m")
    doc = _plan(office.map, *leave, ends=("p0", "p3"))
    assert doc["hour_observed"] is False  # the best of two departures at 07:xx
    assert [r["hour_observed"] for r in doc["departures"]] == [False, False]
    import aion_cli as aion

    api = aion.Map.load(office.map).plan("p0", "p3", time="2026-11-30 07:00", tz="UTC")
    assert api.hour_observed is False
    assert api.to_dict()["hour_observed"] is False


def _figure_text(monkeypatch: pytest.MonkeyPatch, *args: str | Path) -> str:
    """The text of the one figure the command saves as a PNG (titles, legend, caption),
    whitespace collapsed: what a reader of the picture sees written on it."""
    (text,) = figure_texts(monkeypatch, *args)
    return text


@pytest.mark.parametrize(
    ("when", "seen"), [("2026-11-30 07:00", False), ("2026-11-30 08:05", True)]
)
def test_a_plan_picture_at_an_hour_no_log_observed_says_so(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, when: str, seen: bool
) -> None:
    """Before: ``plan --png`` at 07:00 on the office map (observed 08:00-08:20 UTC) drew its
    costs in the legend with nothing to say they came from extrapolated flows, while the table
    said it in its title. Now the picture's title says it in the table's words; at 08:05 (an
    hour observed) neither does. The legend's costs are the JSON's."""
    png = tmp_path / f"{when[-5:].replace(':', '')}.png"
    at = ("--from", "p0", "--to", "p3", "--tz", "UTC", "--time", when)
    text = _figure_text(monkeypatch, "plan", office.map, *at, "--png", png)
    assert png.stat().st_size > 0
    doc = _plan(office.map, "--time", when, ends=("p0", "p3"))
    assert doc["hour_observed"] is seen
    assert f"cost {doc['temporal']['cost']:.1f}" in text
    assert ("p0 to p3, departing Mon 2026-11-30 " + when[-5:] + " UTC") in text
    marked = "departing Mon 2026-11-30 07:00 UTC (extrapolated: an hour no log observed)"
    assert (marked in text) is not seen
    assert ("extrapolated" in text) is not seen


def test_an_export_picture_says_which_times_are_extrapolated(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``export --format png`` at one time says it as ``predict --time``'s title does; a series'
    panels each say ``(extrapolated)``, as a series' table marks its rows; not at 08:05."""
    one = ("--tz", "UTC", "--format", "png")
    text = _figure_text(monkeypatch, "export", office.map, "--time", "2026-11-30 07:00", *one,
                        "-o", tmp_path / "one.png")
    assert "Mon 2026-11-30 07:00 UTC (extrapolated: an hour no log observed)" in text
    monkeypatch.undo()
    seen = _figure_text(monkeypatch, "export", office.map, "--time", "2026-11-30 08:05", *one,
                        "-o", tmp_path / "seen.png")
    assert "Mon 2026-11-30 08:05 UTC" in seen
    assert "extrapolated" not in seen
    monkeypatch.undo()
    series = _figure_text(
        monkeypatch, "export", office.map, "--from", "2026-11-30 07:00", "--to",
        "2026-11-30 09:00", "--step", "1h", *one, "-o", tmp_path / "series.png",
    )
    for clock, seen_then in (("07:00", False), ("08:00", True), ("09:00", False)):
        assert (f"{clock} (extrapolated)" in series) is not seen_then, clock
    assert "no log observed" not in series  # a panel's mark is the one word, as a row's


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--leave", SPAN, "--time", "now"], "--time or --leave"),
        (["--step", "1h"], "--step needs --leave"),
        (["--leave", "2026-01-12 09:00"], "expected START..END"),
        (["--leave", "2026-01-12 10:00..2026-01-12 09:00"], "not after the start"),
        (["--leave", SPAN, "--step", "1s"], "would have 21,601 departures (at most 1,000)"),
    ],
)
def test_bad_departure_options(office: Office, extra: list[str], fragment: str) -> None:
    result = run("plan", office.map, "--from", "p0", "--to", "p2", *extra)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, fragment)


def test_the_api_finds_the_same_departure(sample_map: Path) -> None:
    import aion_cli as aion

    cli = _plan(sample_map, "--leave", SPAN, "--step", "1h")
    cli.pop("map")
    start, end = SPAN.split("..")
    plan = aion.Map.load(sample_map).plan("p103", "p2", leave=(start, end), step="1h", tz="UTC")
    assert plan.to_dict() == cli
    assert sum(d["best"] for d in plan.departures) == 1
    with pytest.raises(aion.InputError, match="step"):
        aion.Map.load(sample_map).plan("p103", "p2", leave=(start, end), step=0.5)


def test_departures_share_the_shortest_path_and_each_times_forecast(
    sample_map: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The distance-only path does not depend on the departure and is searched once; each
    window's forecast is predicted once for all departures, temporal plan and distance-only
    cost alike (every departure searched both again and predicted each time twice: about 3x
    slower on 10^5 places)."""
    import aion_cli as aion
    from aion_cli.engine import planning, query

    searched: list[bool] = []
    predicted: list[int] = []
    real_plan, real_predict = planning.plan, query.predict_table

    def plan_spy(*args: Any, **kwargs: Any) -> Any:
        searched.append(args[5] is None)  # node_cost None: the distance-only search
        return real_plan(*args, **kwargs)

    def predict_spy(state: Any, t_ns: int) -> Any:
        predicted.append(t_ns)
        return real_predict(state, t_ns)

    monkeypatch.setattr(planning, "plan", plan_spy)
    monkeypatch.setattr(query, "predict_table", predict_spy)
    m = aion.Map.load(sample_map)
    best = m.plan("p103", "p2", leave=("2026-01-12 08:00", "2026-01-12 09:00"), tz="UTC")
    assert len(best.departures) == 7
    assert searched.count(True) == 1
    assert searched.count(False) == 7
    assert len(predicted) == len(set(predicted))


@pytest.mark.parametrize("end", ["12:00", "+6h", "2026-01-12 12:00"])
def test_an_end_given_as_a_clock_or_relative_counts_from_the_start(
    sample_map: Path, end: str
) -> None:
    """``--leave "2026-01-12 06:00..12:00"`` is six hours on the 12th (read alone, ``12:00``
    is today's: 581 departures over days were planned for such a span)."""
    doc = _plan(sample_map, "--leave", f"2026-01-12 06:00..{end}", "--step", "1h")
    assert [r["depart"][:16] for r in doc["departures"]] == [
        f"2026-01-12 {h:02d}:00" for h in range(6, 13)
    ]
