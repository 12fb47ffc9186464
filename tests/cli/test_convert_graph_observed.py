"""``aion convert --graph`` writes the scene graph only with detection messages, so the
graph it adds makes no window observed that the detections do not. Before, the graph went
every 60 s from the first message to the last: two 20-minute sessions a day apart built as
a fixed sensor over 146 windows (24.3 h) instead of the 4 the detections hold."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.atc_sessions import SPAN, convert_atc, observed_windows, write_two_sessions
from tests.cli.conftest import run_json

GRAPH = Path(__file__).resolve().parents[1] / "data" / "dsg" / "apartment_dsg.json"


@pytest.fixture(scope="module")
def two(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_two_sessions(tmp_path_factory.mktemp("two") / "two.csv")


@pytest.mark.parametrize("spans", [(), ("--observed", SPAN)], ids=["detections", "observed"])
def test_the_graph_convert_adds_observes_no_window(
    two: Path, tmp_path: Path, spans: tuple[str, ...]
) -> None:
    """Without spans the detections hold 4 windows of 10 min (08:00-08:20 on each day);
    with the span to 12:02 the 23rd observes 24 + 0.2 windows. Converting with --graph
    builds the same observed-window array as without it, and the graph is applied (its 185
    places are the map's nodes) from one graph per minute of detections, not one per minute
    of the whole day."""
    graph = GRAPH
    with_graph, plain = tmp_path / "g.mcap", tmp_path / "p.mcap"
    convert_atc(two, with_graph, "--graph", str(graph), *spans)
    convert_atc(two, plain, *spans)
    g = run_json("build", with_graph, "-o", tmp_path / "g.aion", "--format", "json")
    p = run_json("build", plain, "-o", tmp_path / "p.aion", "--format", "json")
    a, b = observed_windows(tmp_path / "g.aion"), observed_windows(tmp_path / "p.aion")
    assert a.tobytes() == b.tobytes()
    if not spans:
        assert b.max() == pytest.approx(4 - 1 / 30)  # the last window to its 10 s step
    assert g["windows"] == p["windows"]
    assert g["nodes"] == 185  # the places of the graph
    assert p["nodes"] == 0
    assert g["graph"]["messages"] == 40  # each person's first detection opens a minute


def test_a_log_without_detections_still_gets_its_graph(two: Path, tmp_path: Path) -> None:
    """Nobody came: the log marks the span only; the graph goes once, at the first marker
    of the span, the log's start. Built with a log of detections, the map
    has the graph's places and observes what it does without the graph."""
    empty = tmp_path / "none.csv"
    empty.write_text("")
    people = tmp_path / "people.mcap"
    convert_atc(two, people)
    out = {}
    for name, extra in (("g", ("--graph", str(GRAPH))), ("p", ())):
        convert_atc(empty, tmp_path / f"{name}.mcap", "--observed", SPAN, *extra)
        out[name] = run_json("build", people, tmp_path / f"{name}.mcap", "-o",
                             tmp_path / f"{name}.aion", "--format", "json")
    assert out["g"]["graph"]["messages"] == 1
    assert out["g"]["nodes"] == 185
    graph_windows = observed_windows(tmp_path / "g.aion")
    assert graph_windows.tobytes() == observed_windows(tmp_path / "p.aion").tobytes()


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_graph_in_another_log_than_the_detections_is_not_said_missing(
    two: Path, tmp_path: Path, workers: str
) -> None:
    """The people on the 23rd and 24th in one log, the graph in a log of a span the day
    after with nobody in it: the map has the graph's 185 places, with --workers 2 too, and
    no note says there is no scene graph (the people's shard, which read none, said it).
    Two logs without a graph keep the note."""
    people, span = tmp_path / "people.mcap", tmp_path / "span.mcap"
    convert_atc(two, people)
    empty = tmp_path / "none.csv"
    empty.write_text("")
    convert_atc(empty, span, "--observed", "2026-11-25 08:00..2026-11-25 08:30",
                "--graph", str(GRAPH))
    built = run_json("build", people, span, "-o", tmp_path / "m.aion", "--format", "json",
                     "--workers", workers)
    assert built["nodes"] == 185
    assert len(built["workers"]) == (2 if workers == "2" else 0)
    assert not [n for n in built["notes"] if "no scene graph" in n]
    plain = tmp_path / "plain.mcap"
    convert_atc(empty, plain, "--observed", "2026-11-25 08:00..2026-11-25 08:30")
    without = run_json("build", people, plain, "-o", tmp_path / "p.aion", "--format", "json",
                       "--workers", workers)
    assert without["nodes"] == 0
    assert [n for n in without["notes"] if n.startswith("no scene graph: ")] == [
        "no scene graph: flows are kept on hash cells (try --graph FILE or --derive-graph)"
    ]


LONE_SPANS = {
    "two-spans": (("2026-11-25 08:05..2026-11-25 08:17", "2026-11-25 09:00..2026-11-25 09:05"),
                  1.7, 3),
    "short-first": (("2026-11-25 08:05..2026-11-25 08:07", "2026-11-25 08:08..2026-11-25 08:09",
                     "2026-11-25 09:00..2026-11-25 09:05"), 0.8, 2),
}


@pytest.mark.parametrize("case", list(LONE_SPANS))
@pytest.mark.parametrize("workers", ["1", "2"])
def test_the_lone_graph_observes_no_more_of_a_window_than_its_span(
    two: Path, tmp_path: Path, case: str, workers: str
) -> None:
    """Spans on the 25th, nobody in them, beside the people's log. 08:05-08:17 and
    09:00-09:05: 08:00-08:10 is observed from 08:05 (0.5), 08:10-08:20 to 08:17 (0.7),
    09:00-09:10 to 09:05 (0.5), so 1.7 windows over the people's 4 - 1/30, in 3 windows
    without a detection. The graph went to the middle marker of the longest span, 08:11, and
    made 08:10-08:20, a window inside the log, count whole (2.0); at the log's first marker,
    08:05, it was still a message: the note counted 2 windows without one, and with a first
    span shorter than the rest of its window (08:05-08:07, 08:08-08:09: 0.3 of 08:00-08:10)
    the log's own start counted that window from 08:05 on (0.5). The graph at a marker's
    stamp is a marker: same windows, same note, as without the graph."""
    spans, share, silent = LONE_SPANS[case]
    empty = tmp_path / "none.csv"
    empty.write_text("")
    people = tmp_path / "people.mcap"
    convert_atc(two, people)
    observed = [a for span in spans for a in ("--observed", span)]
    windows, notes = {}, {}
    for name, extra in (("g", ("--graph", str(GRAPH))), ("p", ())):
        convert_atc(empty, tmp_path / f"{name}.mcap", *observed, *extra)
        built = run_json("build", people, tmp_path / f"{name}.mcap", "-o",
                         tmp_path / f"{name}.aion", "--format", "json", "--workers", workers)
        windows[name] = observed_windows(tmp_path / f"{name}.aion")
        notes[name] = [n for n in built["notes"] if "window(s)" in n and "observed" in n]
    assert windows["p"].max() == pytest.approx(4 - 1 / 30 + share)
    assert windows["g"].tobytes() == windows["p"].tobytes()
    assert notes["g"] == notes["p"] == [
        # the log's own spans (no --observed given), their windows holding its empty markers
        f"the observed spans the logs record: {silent} window(s) with no message but the logs' "
        f"empty markers taken as observed ({silent}0 min), the time between the logs included"
    ]
