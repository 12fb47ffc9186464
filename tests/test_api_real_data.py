"""The Python API against the command line on real data: an hour of the ATC shopping centre
(Osaka, tests/shared_data.py), converted to a log and built into a map of Tokyo time with a
derived graph. Every query the API answers is the command's JSON, and a time given in each
form the API takes (text in the map's zone, UNIX seconds as text, an aware ``datetime``, a
``numpy.datetime64`` wall-clock time, integer nanoseconds) is the same instant as the
command's ``--time`` in its forms (UNIX seconds, an offset)."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.errors import NoPathError
from tests.cli.conftest import run, run_json
from tests.shared_data import needs, shared

ATC_HOUR = shared("atc", "atc-1024-11_test.csv")  # 11:00-12:00 JST, 24 Oct 2012
pytestmark = needs(ATC_HOUR, "the ATC 11:00 test split")

LOCAL = "2012-10-24 11:30"  # Tokyo (UTC+9): 02:30 UTC
UTC_NS = int(datetime(2012, 10, 24, 2, 30, tzinfo=UTC).timestamp()) * 10**9


@pytest.fixture(scope="module")
def atc(tmp_path_factory: pytest.TempPathFactory) -> aion.Map:
    folder = tmp_path_factory.mktemp("atc")
    log = folder / "atc11.mcap"
    converted = run("convert", ATC_HOUR, "--layout", "atc", "-o", log, "-q")
    assert converted.exit_code == 0, converted.stderr
    return aion.build(log, folder / "atc11.aion", tz="Asia/Tokyo", derive_graph=True)


def _cli(m: aion.Map, *args: str) -> Any:
    """``aion COMMAND MAP ARGS --format json`` of the map ``m``, parsed."""
    assert m.path is not None
    return run_json(args[0], m.path, *args[1:], "--format", "json")


def test_predict_equals_the_commands_json_for_every_form_of_the_time(atc: aion.Map) -> None:
    table = atc.predict(LOCAL, top=5)
    assert table.time_ns == UTC_NS  # the naive text read in the map's zone, as --time
    assert table.zone == "Asia/Tokyo"
    assert len(table) == 5
    assert table.to_dict() == _cli(atc, "predict", "--time", LOCAL, "--top", "5")
    forms: list[aion.api.TimeLike] = [
        str(UTC_NS // 10**9),
        "2012-10-24T02:30:00Z",
        datetime(2012, 10, 24, 2, 30, tzinfo=UTC),
        datetime(2012, 10, 24, 11, 30),  # naive: the map's zone
        np.datetime64("2012-10-24T11:30"),  # its wall-clock time, in the map's zone
        UTC_NS,
        np.int64(UTC_NS),
    ]
    for when in forms:
        assert atc.predict(when, top=5) == table, when
    for text in (str(UTC_NS // 10**9), "2012-10-24T12:30:00+10:00"):
        assert _cli(atc, "predict", "--time", text, "--top", "5") == table.to_dict()


def test_series_plan_and_history_equal_the_commands_json(atc: aion.Map) -> None:
    series = atc.predict_series("2012-10-24 11:00", "12:00", "15m", layer="places", top=4)
    assert series.to_dict() == _cli(
        atc, "predict", "--from", "2012-10-24 11:00", "--to", "12:00", "--step", "15m",
        "--layer", "places", "--top", "4",
    )  # fmt: skip
    assert series.flow.shape == (4, 5)
    for k, when in enumerate(series.times_ns):  # each value is predict's at that time
        at = {r["id"]: r["flow"] for r in atc.predict(when, layer="places").records()}
        assert [at[e["id"]] for e in series.entries] == list(series.flow[:, k])
    history = atc.predict(historical=True, layer="places", top=3)
    assert history.to_dict() == _cli(atc, "predict", "--historical", "--layer", "places",
                                     "--top", "3")
    places = atc.predict(LOCAL, layer="places").records()
    start = places[0]  # the busiest place, from its point; to the quietest one it reaches
    for goal in reversed(places[1:]):  # (the derived graph has several components)
        try:
            plan = atc.plan((start["x"], start["y"]), goal["id"], time=LOCAL)
            break
        except NoPathError:
            continue
    assert len(plan.nodes) > 2
    cli = _cli(atc, "plan", "--from", f"{start['x']!r},{start['y']!r}", "--to", goal["id"],
               "--time", LOCAL)
    assert cli.pop("map") == str(atc.path)
    assert plan.to_dict() == cli
    assert plan.nodes[0] == start["id"]
    assert plan.nodes[-1] == goal["id"]
