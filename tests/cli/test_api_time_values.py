"""The Python API's time values: steps as ``timedelta`` / ``numpy.timedelta64``, times as
``numpy.datetime64`` and pandas ``Timestamp`` (to the nanosecond), read as the strings they
stand for."""

from __future__ import annotations

from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.errors import InputError
from tests.cli.conftest import Office, run_json

T = "2026-01-12 08:40"  # the office log's Monday (tests/cli/logdata.py)


@pytest.fixture(scope="module")
def m(office: Office) -> aion.Map:
    return aion.Map.load(office.map)


def test_a_step_may_be_a_timedelta(m: aion.Map) -> None:
    """A ``timedelta`` step is its seconds (before: "step must be a number", with the hint
    "an int or a float, not a string", though strings such as "30m" are steps)."""
    a = m.predict_series(T, "2026-01-12 10:40", timedelta(hours=1), tz="UTC", top=3)
    b = m.predict_series(T, "2026-01-12 10:40", "1h", tz="UTC", top=3)
    assert a.to_dict() == b.to_dict()
    assert len(a.times) == 3
    p = m.plan("p1", "p2", leave=(T, "2026-01-12 09:10"), step=timedelta(minutes=10), tz="UTC")
    assert len(p.departures) == 4


def test_a_step_may_be_a_numpy_timedelta64(m: aion.Map) -> None:
    """numpy's ``timedelta64`` is its seconds, as a ``timedelta`` (before: ``TypeError:
    float() argument must be ... not 'datetime.timedelta'``, as numbers counts it a number)."""
    a = m.predict_series(T, "2026-01-12 10:40", np.timedelta64(30, "m"), tz="UTC", top=3)
    b = m.predict_series(T, "2026-01-12 10:40", "30m", tz="UTC", top=3)
    assert a == b
    assert len(a.times) == 5
    p = m.plan("p1", "p2", leave=(T, "2026-01-12 09:10"), step=np.timedelta64(600, "s"), tz="UTC")
    assert len(p.departures) == 4
    with pytest.raises(InputError, match="step must be a duration"):
        m.predict_series(T, "2026-01-12 10:40", np.timedelta64(1, "M"), tz="UTC")


def test_a_numpy_timedelta64_where_a_number_is_wanted_is_refused_by_name(
    m: aion.Map, office: Office, tmp_path: Path
) -> None:
    """numpy's ``timedelta64`` counts as an integer to ``numbers``, so a number argument
    passed its checks and ``float()`` then raised a bare ``TypeError`` from inside
    (``m.plan(..., speed=np.timedelta64(1, "s"))``, ``m.holdout(..., radius=...)``): an
    ``InputError`` naming the argument now. ``graph_period`` takes one as its duration (a
    test of tests/test_pipeline_graphs.py builds with it); one of months is refused by name."""
    with pytest.raises(InputError, match="speed must be a number"):
        m.plan("p1", "p2", time=T, tz="UTC", speed=np.timedelta64(1, "s"))  # type: ignore[arg-type]
    with pytest.raises(InputError, match="graph_period must be a duration"):
        aion.build(office.log, tmp_path / "x.aion", graph_period=np.timedelta64(1, "M"))
    with pytest.raises(InputError, match="graph_period must be a duration"):
        aion.build(office.log, tmp_path / "x.aion", graph_period=[5])  # type: ignore[arg-type]
    assert not (tmp_path / "x.aion").exists()


def test_a_duration_where_a_time_count_or_node_is_wanted_is_an_input_error(m: aion.Map) -> None:
    """``m.predict(np.timedelta64(2, "h"))`` raised ``TypeError: int() argument must be ...
    not 'datetime.timedelta'`` from inside (numpy's timedelta64 is an integer to ``numbers``),
    and so did ``top=`` or ``nodes=`` one; a duration is refused by name now, a time with the
    relative text that says "in two hours"."""
    for duration in (np.timedelta64(2, "h"), timedelta(hours=2)):
        with pytest.raises(InputError, match=r"not a time: .* \(a duration\)") as caught:
            m.predict(duration)  # type: ignore[arg-type]
        assert '"+2h"' in str(caught.value.hint)
    with pytest.raises(InputError, match="top must be a whole number"):
        m.predict(T, tz="UTC", top=np.timedelta64(3, "s"))  # type: ignore[arg-type]
    with pytest.raises(InputError, match="is not a node id"):
        m.predict(T, tz="UTC", nodes=[np.timedelta64(3, "h")])  # type: ignore[list-item]
    with pytest.raises(InputError, match="start must be a point"):
        m.plan(np.timedelta64(3, "h"), "p2", time=T, tz="UTC")  # type: ignore[arg-type]
    assert m.predict(T, tz="UTC", top=np.int64(2)) == m.predict(T, tz="UTC", top=2)


def test_a_date_is_its_midnight_as_the_text_of_the_day(m: aion.Map, office: Office) -> None:
    """``m.predict(date(2026, 1, 12))`` was "not a time", though the text ``"2026-01-12"``
    (``--time 2026-01-12``) is that day's midnight in the zone: a ``date`` is read as its
    text now, in predict, a series and to_ns alike."""
    from datetime import date

    day = date(2026, 1, 12)
    table = m.predict(day, tz="Europe/Madrid", top=3)
    assert table.time == "2026-01-12 00:00:00+01:00"
    assert table == m.predict("2026-01-12", tz="Europe/Madrid", top=3)
    cli = run_json("predict", office.map, "--time", "2026-01-12", "--tz", "Europe/Madrid",
                   "--top", "3", "--format", "json")
    assert table.to_dict() == cli
    week = m.predict_series(day, date(2026, 1, 19), "1d", tz="UTC", top=2)
    assert week == m.predict_series("2026-01-12", "2026-01-19", "1d", tz="UTC", top=2)
    assert len(week.times) == 8
    assert aion.to_ns(day) == aion.to_ns("2026-01-12") == 1_768_176_000 * 10**9


def test_a_numpy_datetime64_is_a_naive_time(m: aion.Map) -> None:
    """numpy's ``datetime64`` (what a numpy array of times holds, without pandas) is its
    wall-clock time in the zone, as a naive ``datetime`` (before: "not a time")."""
    utc_ns = 1_768_207_200 * 10**9  # 2026-01-12 08:40 UTC
    assert aion.to_ns(np.datetime64("2026-01-12T08:40")) == utc_ns
    assert aion.to_ns(np.datetime64("2026-01-12T08:40:00.000000123")) == utc_ns + 123
    assert aion.to_ns(np.datetime64("2026-01-12T08:40"), "Europe/Berlin") == utc_ns - 3600 * 10**9
    table = m.predict(np.datetime64("2026-01-12T08:40"), tz="UTC")
    assert table.time_ns == utc_ns
    assert table.records() == m.predict(T, tz="UTC").records()
    series = m.predict_series(np.datetime64(T), np.datetime64("2026-01-12T10:40"), tz="UTC")
    assert series.times_ns == [utc_ns + k * 3600 * 10**9 for k in range(3)]
    with pytest.raises(InputError, match="not a time"):
        m.predict(np.datetime64("NaT"))
    with pytest.raises(InputError, match="outside the range"):
        m.predict(np.datetime64("2300-01-01"))


def test_a_pandas_timestamp_is_read_to_the_nanosecond() -> None:
    """A pandas ``Timestamp`` (a ``datetime`` that holds nanoseconds) keeps them, as a
    ``numpy.datetime64`` does: before, its nanoseconds were dropped (``...08:40:00.000000123``
    was ``...08:40:00``). ``pandas.NaT`` (a ``datetime`` too) was "the time 'NaT' is outside the
    range aion handles"; it is a missing time, as numpy's NaT."""
    pd = pytest.importorskip("pandas", reason="pandas is not installed (aion does not need it)")
    utc_ns = 1_768_207_200 * 10**9  # 2026-01-12 08:40 UTC
    assert aion.to_ns(pd.Timestamp("2026-01-12 08:40:00.000000123")) == utc_ns + 123
    berlin = pd.Timestamp("2026-01-12 09:40:00.000000123", tz="Europe/Berlin")
    assert aion.to_ns(berlin) == utc_ns + 123
    assert aion.to_ns(pd.Timestamp("1969-12-31 23:59:59.999999999")) == -1
    with pytest.raises(InputError, match="not a time") as caught:
        aion.to_ns(pd.NaT)
    assert caught.value.hint == "NaT marks a missing time"
