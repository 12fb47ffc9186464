"""The Python API's results as values in a notebook: ``repr`` says what a result is in one
line (a table of 10^5 entries printed every record, tens of megabytes, seconds to make), and
two series of the same prediction compare equal (the generated ``==`` raised ``ValueError``
on their arrays)."""

from __future__ import annotations

from pathlib import Path

import pytest

import aion_cli as aion
from tests.cli.conftest import run_json

T = "2026-01-12 08:40"  # a Monday of the bundled sample
AT_JSON = ("--time", T, "--tz", "UTC", "--format", "json")


@pytest.fixture(scope="module")
def m(sample_map: Path) -> aion.Map:
    return aion.Map.load(sample_map)


def test_a_table_s_repr_is_one_short_line(m: aion.Map, sample_map: Path) -> None:
    cli = run_json("predict", sample_map, *AT_JSON)
    n, busiest = len(cli["entries"]), cli["entries"][0]["id"]
    assert n > 20  # enough records that printing them all is far longer than a line
    text = repr(m.predict(T, tz="UTC"))
    # before: Table(map=..., entries=({'id': ..., 'histogram': [...]}, ...)), every record
    assert text.startswith(f"<aion.Table {m.path} at {cli['time']}: {n:,} entries")
    assert f"busiest {busiest}" in text
    assert "\n" not in text
    assert len(text) < 160
    observed = repr(m.predict(historical=True))
    assert observed.startswith(f"<aion.Table {m.path} as observed: ")
    assert len(observed) < 160


def test_a_plan_s_repr_sums_it_up(m: aion.Map, sample_map: Path) -> None:
    cli = run_json("plan", sample_map, "--from", "p103", "--to", "p2", *AT_JSON)
    text = repr(m.plan("p103", "p2", time=T, tz="UTC"))
    temporal, shortest = cli["temporal"], cli["distance_only"]
    assert text.startswith(f"<aion.Plan p103 -> p2 at {cli['depart']}: ")
    assert f"{len(temporal['path'])} nodes, {temporal['length_m']:.1f} m" in text
    assert f"distance only {len(shortest['path'])} nodes, {shortest['length_m']:.1f} m" in text
    assert len(text) < 200  # before: every node and arrival time
    best = m.plan("p103", "p2", leave=(T, "09:40"), step="30m", tz="UTC")
    assert repr(best).endswith("; the best of 3 departures>")


def test_a_series_repr_is_one_line(m: aion.Map) -> None:
    day = m.predict_series("2026-01-12 06:00", "2026-01-12 20:00", "1h", tz="UTC")
    text = repr(day)
    # before: SeriesTable(times_ns=[...], entries=[...], flow=array(...), ...)
    assert text == (  # named as the API names it, as <aion.Table and <aion.Plan (before:
        # <SeriesTable, which no name of the API is)
        f"<aion.SeriesTable {m.path}: {len(day.entries)} entries x 15 times, "
        "2026-01-12 06:00:00+00:00 .. 2026-01-12 20:00:00+00:00>"
    )
    assert type(day) is aion.SeriesTable


def test_two_series_of_the_same_prediction_are_equal(m: aion.Map) -> None:
    day = m.predict_series("2026-01-12 06:00", "2026-01-12 20:00", "1h", tz="UTC")
    again = m.predict_series("2026-01-12 06:00", "2026-01-12 20:00", "1h", tz="UTC")
    assert again == day  # before: ValueError (the truth value of an array is ambiguous)
    shorter = m.predict_series("2026-01-12 06:00", "2026-01-12 19:00", "1h", tz="UTC")
    assert shorter != day


def test_a_holdout_result_s_repr_is_its_scores(m: aion.Map) -> None:
    log = Path(__file__).resolve().parents[2] / "samples" / "office.mcap"
    cli = run_json("evaluate", "holdout", m.path, log, "--format", "json")
    with pytest.warns(aion.AionWarning, match="within the map's own time span"):  # in-sample
        text = repr(m.holdout([log]))
    # before: HoldoutResult(headings=[...], ..., hours=[every hour], series={every value});
    # then <HoldoutResult: ...>, unlike the <aion.… > of every other result and report
    assert text.startswith(f"<aion.HoldoutResult: {cli['test']['detections']:,} test detections, "
                           f"{len(cli['hours'])} hours; heading NLL ")
    for row in cli["headings"]:
        assert f"{row['model']} {row['nll_all']:.3g}" in text
    for row in cli["activity"]:
        assert f"{row['model']} {row['spearman']:.3g}" in text
    assert cli["hours"][0] not in text


def test_records_are_copies_to_change(m: aion.Map, sample_map: Path) -> None:
    """docs/API.md: ``records()`` gives fresh copies to change. Before, a record's
    ``speed_per_bin`` was the table's own list: changing it changed the table."""
    cli = run_json("predict", sample_map, *AT_JSON, "--top", "3")
    table = m.predict(T, tz="UTC", top=3)
    for row in table.records():
        row["histogram"][0] = row["speed_per_bin"][0] = -1.0
        row["flow"] = -1.0
    assert table.to_dict() == cli
    assert table.records() == cli["entries"]


def test_documents_are_copies_to_change(m: aion.Map) -> None:
    """A series' ``to_dict()`` handed out its own ``times_ns`` list, and a plan's its
    snapped points' coordinates: changing the document changed the result."""
    day = m.predict_series("2026-01-12 06:00", "2026-01-12 08:00", "1h", tz="UTC", top=2)
    doc = day.to_dict()
    doc["times_ns"].append(0)
    assert len(day.times_ns) == len(day.to_dict()["times_ns"]) == 3
    plan = m.plan("3.0,4.0", "p2", time=T, tz="UTC")
    doc = plan.to_dict()
    doc["snapped"][0]["point"][0] = -1.0
    assert plan.to_dict()["snapped"][0]["point"] == [3.0, 4.0]


def test_a_series_counts_and_yields_its_records_as_a_table_does(m: aion.Map) -> None:
    """``len(t)`` and ``for row in t`` work on a Table; on a series they raised TypeError
    ('SeriesTable' has no len(), is not iterable)."""
    day = m.predict_series("2026-01-12 06:00", "2026-01-12 08:00", "1h", tz="UTC", layer="rooms")
    rooms = m.predict(T, tz="UTC", layer="rooms")
    assert len(day) == len(rooms) == len(day.entries)
    assert list(day) == day.records()
    assert sorted(row["id"] for row in day) == sorted(row["id"] for row in rooms)


def test_a_manifest_s_repr_is_one_line(m: aion.Map, sample_map: Path) -> None:
    """``m.manifest`` in a notebook printed the dataclass whole: the model parameters,
    every input's sha256 and every place's label (4.7 kB for the sample, growing with the
    places and logs). Now one line, with what ``aion info`` shows first."""
    counts = run_json("info", sample_map, "--format", "json")["counts"]
    text = repr(m.manifest)
    assert "\n" not in text
    assert m.manifest.inputs[0].sha256 not in text
    assert text.startswith("<aion.Manifest: 2026-01-05 00:00:00+00:00 .. 2026-01-09 23:59:59")
    assert f"; {counts['used']:,} detections used from 1 log; " in text
    assert text.endswith(f"; {counts['nodes']:,} nodes, {counts['cells']:,} cells>")


def test_results_compare_by_value_and_none_is_hashable(m: aion.Map) -> None:
    """Tables, plans and series are frozen values whose records are dicts, lists and arrays:
    equal results compare equal, and ``hash`` refuses every one of them alike, naming its
    type. Before, a table's and a plan's hash raised ``unhashable type: 'dict'`` / ``'list'``
    from inside, and a table without entries had a hash."""
    from dataclasses import replace

    table, plan = m.predict(T, tz="UTC"), m.plan("p103", "p2", time=T, tz="UTC")
    series = m.predict_series(T, "09:40", "30m", tz="UTC")
    empty = replace(table, entries=())
    assert table == m.predict(T, tz="UTC")
    assert plan == m.plan("p103", "p2", time=T, tz="UTC")
    assert series == m.predict_series(T, "09:40", "30m", tz="UTC")
    for value, name in ((table, "Table"), (empty, "Table"), (plan, "Plan"),
                        (series, "SeriesTable")):
        with pytest.raises(TypeError, match=f"unhashable type: '{name}'"):
            hash(value)


def test_a_map_state_s_repr_is_one_line(sample_map: Path) -> None:
    """``m.state`` (docs/API.md: "the engine state") in a notebook printed the generated
    dataclass repr: every array and the config, 160 kB for the sample's 151 entries. It is one
    line of its counts now, the same as ``aion info``'s."""
    info = run_json("info", sample_map, "--format", "json")
    counts, entries = info["counts"], int(info["entries"])
    m = aion.Map.load(sample_map)
    nodes = entries - counts["cells"]
    assert repr(m.state) == (
        f"<MapState: {entries:,} entries ({nodes:,} nodes, {counts['cells']:,} cells), "
        f"{counts['used']:,} detections accepted, 8 direction bins, read for queries>"
    )


def test_nodes_as_any_iterable_and_counts_as_numpy_integers_answer_as_a_list(
    m: aion.Map,
) -> None:
    """``nodes=`` was typed a sequence, though the API reads any iterable of ids (a set, a
    numpy array of ids, a generator), and ``top`` / ``workers`` / ``batch_size`` plain ints,
    though numpy's are read alike: the annotations admit them now (tests/test_api_types.py),
    and each answers as the list and the int do."""
    import numpy as np

    ids = [r["id"] for r in m.predict(T, tz="UTC", top=3).records()]
    listed = m.predict(T, tz="UTC", nodes=ids)
    assert len(listed) == 3
    for nodes in (set(ids), np.array(ids), (i for i in ids), dict.fromkeys(ids).keys()):
        assert m.predict(T, tz="UTC", nodes=nodes) == listed
    assert m.predict(T, tz="UTC", top=np.int64(3)) == m.predict(T, tz="UTC", top=3)
