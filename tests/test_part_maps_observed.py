"""``aion merge`` of part maps built with ``--observed`` against one build of the same logs
given every part's spans (``aion_cli/merge_observed.py``).

The logs (``tests/cli/logdata.py``, a fixed sensor with a message in every window of its hour):
Monday 08:00-09:00 and 11:00-12:00 (two logs of one part), Tuesday and Wednesday 08:00-09:00;
windows of 10 minutes. The merge fills the time before, between and after the parts from every
part's spans; the time inside a part's own logs is the part's, and where another part's spans
cover windows there without a message the merge says so (those windows are missing from it).
"""

from __future__ import annotations

import json
import re
from datetime import UTC, datetime, timedelta
from pathlib import Path

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from aion_cli.engine.compare import differences
from aion_cli.mapquery import load_map
from tests.cli.conftest import run
from tests.cli.logdata import write_office_log

HOUR_S = 3600
MONDAY = datetime(2026, 11, 23, tzinfo=UTC)  # the logs' first day (00:00 UTC)
LOGS = {"a0": 8, "a1": 11, "b": 32, "c": 56}  # each log's start, hours after Monday 00:00
PARTS = {"pa": ("a0", "a1"), "pb": ("b",), "pc": ("c",)}


def _logs(folder: Path) -> dict[str, Path]:
    paths = {}
    for name, hour in LOGS.items():
        paths[name] = folder / f"{name}.mcap"
        write_office_log(paths[name], tf=False, shift_s=(hour - 8) * HOUR_S, duration_s=HOUR_S)
    return paths


def _span(start_h: int, end_h: int) -> tuple[str, str]:
    """``--observed`` for the hours ``start_h`` to ``end_h`` after Monday 00:00."""
    def text(h: int) -> str:
        return (MONDAY + timedelta(hours=h)).strftime("%Y-%m-%d %H:%M")

    return ("--observed", f"{text(start_h)}..{text(end_h)}")


def _build(out: Path, logs: list[Path], *options: str) -> Path:
    result = run("build", *logs, "-o", out, "--workers", "1", "-q", *options)
    assert result.exit_code == 0, result.stderr
    return out


def _merge(out: Path, parts: list[Path]) -> list[str]:
    result = run("merge", *parts, "-o", out, "--format", "json")
    assert result.exit_code == 0, result.stderr
    notes: list[str] = json.loads(result.stdout)["notes"]
    return notes


def _windows(path: Path) -> int:
    return int(load_map(path).manifest["counts"]["windows"])


def test_a_window_in_a_part_only_another_parts_span_covers_is_said_to_be_missing(
    tmp_path: Path,
) -> None:
    """Part pa holds Monday 08:00-09:00 and 11:00-12:00; part pb declares Monday 09:00 to
    Tuesday 12:00. One build of the three logs given that span counts Monday 09:00-11:00 (12
    windows, inside pa's time) as observed; pa, built without it, closed them unobserved and
    the merge (which fills Monday 12:00 to Tuesday 08:00 from the span) lacked them without a
    word. It says so now, naming pa and the 12 windows; pa built again with the span, the
    merge equals the build."""
    logs = _logs(tmp_path)
    span = _span(9, 36)
    pa = _build(tmp_path / "pa.aion", [logs["a0"], logs["a1"]], "--part")
    pb = _build(tmp_path / "pb.aion", [logs["b"]], "--part", *span)
    one = _build(tmp_path / "one.aion", [logs["a0"], logs["a1"], logs["b"]], *span)
    merged = tmp_path / "m.aion"
    notes = [n for n in _merge(merged, [pb, pa]) if "not exactly" in n]
    assert len(notes) == 1
    assert notes[0].startswith("pa.aion was joined, but not exactly as one build would: other "
                               "parts' --observed spans cover 12 window(s) (2.0 h) within its "
                               "own logs' time")
    assert _windows(merged) == _windows(one) - 12
    assert differences(load_map(one).state, load_map(merged).state)
    _build(pa, [logs["a0"], logs["a1"]], "--part", *span)
    assert not [n for n in _merge(merged, [pb, pa]) if "not exactly" in n]
    whole, again = load_map(one), load_map(merged)
    assert differences(whole.state, again.state) == []
    assert again.manifest["counts"] == whole.manifest["counts"]
    assert again.manifest["time_span"] == whole.manifest["time_span"]


def test_parts_without_spans_are_filled_around_by_the_others_spans(tmp_path: Path) -> None:
    """pa declares Monday 00:00-20:00, pb and pc declare nothing. One build given that span
    observes Monday 00:00 to 20:00 (120 windows, pa's logs' among them; 48 after its logs,
    12:00-20:00) and the two other logs' hours (12). The merge filled between parts only from
    the later part's own spans: it filled nothing (84 windows) and said one build counts the
    120 windows between pa and pb as observed, though the span covers only 48 of them."""
    logs = _logs(tmp_path)
    span = _span(0, 20)
    parts = [
        _build(tmp_path / "pa.aion", [logs["a0"], logs["a1"]], "--part", *span),
        _build(tmp_path / "pb.aion", [logs["b"]], "--part"),
        _build(tmp_path / "pc.aion", [logs["c"]], "--part"),
    ]
    one = _build(tmp_path / "one.aion", list(logs.values()), *span)
    assert _windows(one) == 120 + 12
    merged = tmp_path / "m.aion"
    assert not [n for n in _merge(merged, [parts[2], parts[0], parts[1]]) if "--observed" in n]
    whole, result = load_map(one), load_map(merged)
    assert differences(whole.state, result.state) == []
    assert result.manifest["counts"] == whole.manifest["counts"]
    assert result.manifest["time_span"] == whole.manifest["time_span"]


_HOURS = st.tuples(st.integers(0, 70), st.integers(1, 30))  # a span's start and length


@settings(
    max_examples=10,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    st.lists(st.lists(_HOURS, max_size=2), min_size=3, max_size=3),
    st.permutations(list(PARTS)),
)
def test_three_parts_in_any_order_with_overlapping_spans_merge_as_one_build(
    tmp_path: Path, declared: list[list[tuple[int, int]]], order: list[str]
) -> None:
    """Each part declares up to two spans of whole hours (overlapping one another, the logs
    and the other parts' time, or not), given in any order: the merge equals one build of
    the four logs given every span, or names the parts whose own time other parts' spans
    cover without a message, and the windows it says are missing are those the build has
    more."""
    folder = tmp_path / f"ex{len(list(tmp_path.iterdir()))}"
    folder.mkdir()
    logs = _logs(folder)
    spans = {
        name: [o for a, n in hours for o in _span(a, a + n)]
        for name, hours in zip(PARTS, declared, strict=True)
    }
    parts = {
        name: _build(folder / f"{name}.aion", [logs[k] for k in keys], "--part", *spans[name])
        for name, keys in PARTS.items()
    }
    every = [o for name in PARTS for o in spans[name]]
    one = _build(folder / "one.aion", list(logs.values()), *every)
    merged = folder / "m.aion"
    notes = [n for n in _merge(merged, [parts[name] for name in order]) if "not exactly" in n]
    missing = sum(int(re.search(r"cover (\d+) window", n)[1]) for n in notes)  # type: ignore[index]
    assert _windows(merged) + missing == _windows(one)
    whole, result = load_map(one), load_map(merged)
    event("noted" if notes else "exact")
    if not notes:
        assert differences(whole.state, result.state) == []
        assert result.manifest["counts"] == whole.manifest["counts"]
        assert result.manifest["time_span"] == whole.manifest["time_span"]
    else:
        assert differences(whole.state, result.state)
