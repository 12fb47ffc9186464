"""Every step form the docs give ``Map.predict_series`` and ``Map.plan`` is accepted, with
the length they say: the docstrings listed fewer forms than docs/API.md (no ``timedelta``
and no ``"1d"`` for ``plan``), so a reader of ``help(m.plan)`` could not tell a day step
was allowed. The forms are checked against the docstrings and API.md too, so they stay one
list."""

from __future__ import annotations

from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest

import aion_cli as aion
from tests.cli.conftest import Office

T0 = 1_768_207_200 * 10**9  # 2026-01-12 08:40 UTC, the office log's Monday (logdata.py)
S = 10**9

FORMS: list[tuple[object, int]] = [
    ("1h", 3600), ("30m", 1800), ("1h30m", 5400), ("600s", 600), ("600", 600), (600, 600),
    (600.0, 600), (timedelta(minutes=30), 1800), (np.timedelta64(30, "m"), 1800),
    ("1d", 86400), ("1w", 7 * 86400),
]  # fmt: skip
"""Each form and its length in seconds (in UTC a calendar day is 86400 s)."""


@pytest.fixture(scope="module")
def m(office: Office) -> aion.Map:
    return aion.Map.load(office.map)


@pytest.mark.parametrize(("step", "seconds"), FORMS, ids=[repr(f) for f, _ in FORMS])
def test_each_step_form_is_accepted_with_its_length(
    m: aion.Map, step: object, seconds: int
) -> None:
    end = T0 + 2 * seconds * S
    series = m.predict_series(T0, end, step, tz="UTC", top=1)  # type: ignore[arg-type]
    assert np.diff(series.times_ns).tolist() == [seconds * S] * 2
    plan = m.plan("p1", "p2", leave=(T0, end), step=step, tz="UTC")  # type: ignore[arg-type]
    assert np.diff([d["depart_ns"] for d in plan.departures]).tolist() == [seconds * S] * 2


def test_a_day_step_is_calendar_days_a_timedelta_day_is_24_hours(m: aion.Map) -> None:
    """Across Berlin's spring change (2026-03-29 02:00 -> 03:00): "1d" keeps 12:00, the
    29th's 23 h after the 28th's; ``timedelta(days=1)`` is 24 h of elapsed time, so 13:00."""
    span = ("2026-03-28 12:00", "2026-03-30 12:00")
    daily = m.predict_series(*span, "1d", tz="Europe/Berlin", top=1)
    assert [t[11:16] for t in daily.times] == ["12:00", "12:00", "12:00"]
    assert np.diff(daily.times_ns).tolist() == [23 * 3600 * S, 86400 * S]
    elapsed = m.predict_series(*span, timedelta(days=1), tz="Europe/Berlin", top=1)
    assert [t[11:16] for t in elapsed.times] == ["12:00", "13:00"]


def test_the_docstrings_and_api_md_list_the_same_forms() -> None:
    api_md = (Path(__file__).resolve().parents[2] / "docs" / "API.md").read_text()
    row = next(line for line in api_md.splitlines() if line.startswith("| `m.predict_series("))
    series_doc, plan_doc = aion.Map.predict_series.__doc__, aion.Map.plan.__doc__
    assert series_doc is not None
    assert plan_doc is not None
    for form in ('"1h"', '"30m"', '"1h30m"', '"600s"', '"1d"', '"1w"'):
        assert f"``{form}``" in series_doc, form
        assert f"`{form}`" in row, form
    for words in ("seconds", "timedelta", "numpy.timedelta64", "timedelta(days=1)` is 24 h"):
        assert words.replace("`", "``") in series_doc, words
        assert words in row, words
    for form in ('``"10m"``', '``"1d"``', "seconds", "``timedelta``", "``numpy.timedelta64``"):
        assert form in plan_doc, form
    assert ":meth:`predict_series`" in plan_doc  # and whatever else it takes
