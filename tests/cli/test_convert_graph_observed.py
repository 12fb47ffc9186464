"""``aion convert --graph`` writes the scene graph only with detection messages, so the
graph it adds makes no window observed that the detections do not. Before, the graph went
every 60 s from the first message to the last: two 20-minute sessions a day apart built as
a fixed sensor over 146 windows (24.3 h) instead of the 4 the detections hold."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import run, run_json

GRAPH = Path(__file__).resolve().parents[1] / "data" / "dsg" / "apartment_dsg.json"
SPAN = "2026-11-23 08:00..2026-11-23 12:02"


@pytest.fixture(scope="module")
def two(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """ATC rows (time s, id, x m, y m, speed, angle): 08:00-08:20 on 2026-11-23 and -24,
    one person a minute walking for 30 s from 5 s past it."""
    rows, person = [], 1
    for day in (23, 24):
        t0 = datetime(2026, 11, day, 8, 0, tzinfo=UTC).timestamp()
        for minute in range(20):
            start = t0 + minute * 60 + 5
            rows += [f"{start + i:.3f},{person},{-10 + i * 0.5:.3f},1.000,0.5,0.0"
                     for i in range(30)]
            person += 1
    path = tmp_path_factory.mktemp("two") / "two.csv"
    path.write_text("\n".join(rows) + "\n")
    return path


def _convert(tracks: Path, log: Path, *args: str) -> None:
    result = run("convert", tracks, "--layout", "atc", "-o", log, "-q", *args)
    assert result.exit_code == 0, result.stderr


def _observed(path: Path) -> np.ndarray:
    from aion_cli.mapquery import load_map

    state = load_map(path).state
    out: np.ndarray = state.windows_observed(state.entries.live_rows(), True)
    return out


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
    _convert(two, with_graph, "--graph", str(graph), *spans)
    _convert(two, plain, *spans)
    g = run_json("build", with_graph, "-o", tmp_path / "g.aion", "--format", "json")
    p = run_json("build", plain, "-o", tmp_path / "p.aion", "--format", "json")
    a, b = _observed(tmp_path / "g.aion"), _observed(tmp_path / "p.aion")
    assert a.tobytes() == b.tobytes()
    if not spans:
        assert b.max() == pytest.approx(4 - 1 / 30)  # the last window to its 10 s step
    assert g["windows"] == p["windows"]
    assert g["nodes"] == 185  # the places of the graph
    assert p["nodes"] == 0
    assert g["graph"]["messages"] == 40  # each person's first detection opens a minute


def test_a_log_without_detections_still_gets_its_graph(two: Path, tmp_path: Path) -> None:
    """Nobody came: the log marks the span only; the graph goes once, at the middle marker
    of the span (a window the span covers whole). Built with a log of detections, the map
    has the graph's places and observes what it does without the graph."""
    empty = tmp_path / "none.csv"
    empty.write_text("")
    people = tmp_path / "people.mcap"
    _convert(two, people)
    out = {}
    for name, extra in (("g", ("--graph", str(GRAPH))), ("p", ())):
        _convert(empty, tmp_path / f"{name}.mcap", "--observed", SPAN, *extra)
        out[name] = run_json("build", people, tmp_path / f"{name}.mcap", "-o",
                             tmp_path / f"{name}.aion", "--format", "json")
    assert out["g"]["graph"]["messages"] == 1
    assert out["g"]["nodes"] == 185
    assert _observed(tmp_path / "g.aion").tobytes() == _observed(tmp_path / "p.aion").tobytes()
