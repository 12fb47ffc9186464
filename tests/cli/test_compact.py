"""``aion compact``: a query-only copy of a map answers every query as the full map does, is
smaller by the Fourier sums it leaves out, and refuses to learn (continue, merge) with a clear
error; bad inputs are refused before anything is written."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.api import Map
from aion_cli.engine.query import predict_table
from aion_cli.engine.temporal.components import PREFIX
from aion_cli.errors import MapFileError
from aion_cli.formats.mapfile import RESERVED_KEYS, open_map, read_manifest, write_map
from aion_cli.mapquery import load_map
from aion_cli.query_only import LEFT_OUT
from tests.cli.conftest import assert_one_line_error, run, run_json
from tests.cli.logdata import write_office_log
from tests.engine.temporal_data import DAY, HOUR, MONDAY, corridor, heading_56h, rhythm_56h


@dataclass(frozen=True)
class Maps:
    full: Path
    small: Path
    summary: dict[str, object]


@pytest.fixture(scope="module")
def maps(tmp_path_factory: pytest.TempPathFactory) -> Maps:
    """21 days of a 56 h rhythm (FreMEn's, per bin and in total) over a small corridor, a
    pending day and an open window (what queries absorb first), saved, then compacted."""
    folder = tmp_path_factory.mktemp("compact")
    mapper = corridor(21, rhythm_56h, cells=(3.0, 1.0), heading=heading_56h)
    mapper.state.observation.set_fixed_sensor(MONDAY + 21 * DAY, MONDAY + 22 * DAY)
    mapper.advance(MONDAY + 21 * DAY + 9 * HOUR + 5 * 60 * 10**9)
    full = folder / "rhythm.aion"
    Map.from_state(mapper.state, timezone="UTC").save(full)
    small = folder / "rhythm-robot.aion"
    summary = run_json("compact", full, "-o", small, "--format", "json")
    return Maps(full, small, summary)


def _times() -> list[int]:
    return [MONDAY + 21 * DAY + k * 5 * HOUR for k in range(14)]


def test_every_forecast_is_the_full_maps_to_the_bit(maps: Maps) -> None:
    whole = load_map(maps.full).state  # read whole: Fourier sums and all
    light = load_map(maps.small).state  # a query-only map is read without them
    assert whole.temporal.fourier_loaded
    assert not light.temporal.fourier_loaded
    families: set[str] = set()
    for t in _times():
        a, b = predict_table(whole, t), predict_table(light, t)
        assert a.flow_family.tolist() == b.flow_family.tolist()
        assert a.direction_family.tolist() == b.direction_family.tolist()
        for name in ("flow", "flow_var", "rate"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        families |= set(a.flow_family.tolist()) | set(a.direction_family.tolist())
    assert any(f.startswith("fremen") for f in families), families  # the case under test


def test_the_cli_and_the_api_answer_alike(maps: Maps) -> None:
    at = "2026-11-23 14:00"  # day 22 of the rhythm, after the pending morning
    a = run_json("predict", maps.full, "--time", at, "--tz", "UTC", "--format", "json")
    b = run_json("predict", maps.small, "--time", at, "--tz", "UTC", "--format", "json")
    assert a.pop("map") != b.pop("map")
    assert a == b
    x = Map.load(maps.full).predict(at, tz="UTC").records()
    y = Map.load(maps.small).predict(at, tz="UTC").records()
    assert x == y


def test_it_leaves_out_the_fourier_sums_and_says_so(maps: Maps) -> None:
    summary = maps.summary
    assert set(summary["left_out"]) == set(LEFT_OUT)  # type: ignore[call-overload]
    assert summary["map_bytes"] == maps.small.stat().st_size
    assert summary["source_bytes"] == maps.full.stat().st_size
    assert maps.small.stat().st_size < maps.full.stat().st_size
    full, small = read_manifest(maps.full), read_manifest(maps.small)
    assert set(full["members"]) - set(small["members"]) == set(LEFT_OUT)
    record = small["query_only"]
    assert record["from"]["sha256"] == hashlib.sha256(maps.full.read_bytes()).hexdigest()
    assert set(record["left_out"]) == set(LEFT_OUT)
    # every kept member is the full map's, byte for byte (same checksums)
    for name in small["members"]:
        assert small["members"][name]["sha256"] == full["members"][name]["sha256"], name
    shown = run_json("info", maps.small, "--format", "json")
    assert shown["query_only"]["from"]["name"] == maps.full.name
    table = run("info", maps.small)
    assert "query only" in table.stdout


def test_info_does_not_call_a_query_only_maps_last_day_open_to_more_logs(maps: Maps) -> None:
    """The full map's last day is scored provisionally, open to the logs that continue it;
    its query-only copy, which cannot be continued, said the same beside 'cannot be
    continued or merged'."""
    assert read_manifest(maps.small)["families"]["last_day_provisional"] is True

    def days_row(path: Path) -> str:
        table = run("info", path)
        assert table.exit_code == 0, table.stderr
        return next(line for line in table.stdout.splitlines() if "days scored" in line)

    assert "still open to more logs" in days_row(maps.full)
    row = days_row(maps.small)
    assert "open to more logs" not in row
    assert "provisionally, as it stood when compacted" in row


def test_a_query_only_map_refuses_to_learn(maps: Maps, tmp_path: Path) -> None:
    before = maps.small.read_bytes()
    log = tmp_path / "more.mcap"
    write_office_log(log)
    result = run("build", log, "--map", maps.small)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "query-only map", "cannot be continued")
    assert maps.full.name in result.stderr  # the hint names the full map
    assert maps.small.read_bytes() == before
    merged = run("merge", maps.full, maps.small, "-o", tmp_path / "both.aion")
    assert merged.exit_code == 2
    assert_one_line_error(merged.stderr, "query-only map", "cannot be merged")
    assert not (tmp_path / "both.aion").exists()
    with pytest.raises(MapFileError, match="query-only"):
        load_map(maps.small, writable=True)


def test_the_api_compacts_too(maps: Maps, tmp_path: Path) -> None:
    made = aion.compact(maps.full, tmp_path / "api.aion")
    assert made.report is not None
    assert made.report.to_dict()["map_bytes"] == (tmp_path / "api.aion").stat().st_size
    at = MONDAY + 21 * DAY + 15 * HOUR
    np.testing.assert_array_equal(
        predict_table(made.state, at).flow, predict_table(load_map(maps.full).state, at).flow
    )


def test_bad_inputs_are_refused_before_anything_is_written(maps: Maps, tmp_path: Path) -> None:
    again = run("compact", maps.small, "-o", tmp_path / "again.aion")
    assert again.exit_code == 2
    assert_one_line_error(again.stderr, "query-only map already")
    same = run("compact", maps.full, "-o", maps.full)
    assert same.exit_code == 2
    assert_one_line_error(same.stderr, "is the map being compacted")
    missing = run("compact", tmp_path / "nope.aion", "-o", tmp_path / "out.aion")
    assert missing.exit_code == 2
    assert_one_line_error(missing.stderr, "not found")
    nowhere = run("compact", maps.full, "-o", tmp_path / "no" / "such" / "robot.aion")
    assert nowhere.exit_code == 2
    assert_one_line_error(nowhere.stderr, "does not exist")
    text = tmp_path / "notes.txt"
    text.write_text("mine")
    other = run("compact", maps.full, "-o", text)
    assert other.exit_code == 2
    assert text.read_text() == "mine"
    # a map written before the FreMEn components were stored: its forecasts need the sums
    with open_map(maps.full) as members:
        arrays = {n: members[n] for n in members if not n.startswith(PREFIX)}
        manifest = {k: v for k, v in members.manifest.items() if k not in RESERVED_KEYS}
    old = tmp_path / "old.aion"
    write_map(old, arrays, manifest)
    refused = run("compact", old, "-o", tmp_path / "old-robot.aion")
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "no FreMEn components")
    assert not (tmp_path / "old-robot.aion").exists()
    # a manifest whose query_only field is not a record: refused by every reader alike
    with open_map(maps.small) as members:
        arrays = {n: members[n] for n in members}
        manifest = {k: v for k, v in members.manifest.items() if k not in RESERVED_KEYS}
    odd = tmp_path / "odd.aion"
    write_map(odd, arrays, manifest | {"query_only": "yes"})
    for args in (("predict", odd, "--time", "2026-11-23 14:00"), ("info", odd)):
        result = run(*args)
        assert result.exit_code == 2, args
        assert_one_line_error(result.stderr, "query_only")


def test_a_part_map_is_refused(tmp_path: Path) -> None:
    log = tmp_path / "day.mcap"
    write_office_log(log)
    part = tmp_path / "part.aion"
    assert run("build", log, "--part", "-o", part, "-q").exit_code == 0
    result = run("compact", part, "-o", tmp_path / "robot.aion")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "part map")
    assert not (tmp_path / "robot.aion").exists()


def _table_cells(text: str) -> dict[str, str]:
    """The rows of a two-column rich table in ``text``: first cell -> second, a cell wrapped
    onto more rows (an empty first cell) joined again with the spaces it was wrapped at."""
    cells: dict[str, str] = {}
    what = ""
    for line in text.splitlines():
        if not line.startswith("│"):
            continue
        left, right = (c.strip() for c in line.strip().strip("│").split("│"))
        if left:
            what = left
            cells[what] = right
        else:
            cells[what] += " " + right
    return cells


def test_the_text_summary_says_what_was_done(maps: Maps, tmp_path: Path) -> None:
    """Without --format json compact printed one "wrote" line: its sizes, not what it left out
    nor for how many entries. It now closes with a table as build and merge do: the map made
    from, both sizes, the entries, the members left out (read here from the two files)."""
    out = tmp_path / "robot.aion"
    result = run("compact", maps.full, "-o", out)
    assert result.exit_code == 0, result.stderr
    text = " ".join(result.stderr.split())
    full, small = read_manifest(maps.full), read_manifest(out)
    gone = sorted(set(full["members"]) - set(small["members"]))
    assert gone  # the Fourier sums
    kib = [f"{p.stat().st_size / 1024:.1f} KiB" for p in (maps.full, out)]
    ratio = maps.full.stat().st_size / out.stat().st_size
    with open_map(out) as members:
        entries = len(members["entry_kind"])  # one row per entry the map answers for
    places = len(run_json("predict", out, "--historical", "--format", "json")["entries"])
    without = places - entries  # predict's rows: the entries and the places that hold none
    # the table wraps a long cell at its spaces (a path with spaces in it) onto rows of its own
    assert _table_cells(result.stderr)["made from"] == str(maps.full)
    for shown in (
        f"query-only map {out}",
        f"full map size │ {kib[0]}",
        f"query-only size │ {kib[1]} ({ratio:.1f}x smaller)",
        f"entries │ {entries:,}" + (f" (+{without} places without data)" if without else " │"),
        "size per entry │",
    ):
        assert shown in text, (shown, text)
    assert all(name in text for name in gone), (gone, text)
    assert "cannot be continued (build --map) or merged" in text
    assert run("compact", maps.full, "-o", tmp_path / "q.aion", "-q").stderr == ""


def test_an_existing_map_at_o_is_replaced_with_a_note(maps: Maps, tmp_path: Path) -> None:
    """As ``build -o`` and ``merge -o`` do: an existing map is replaced, and the user is told."""
    assert maps.summary["notes"] == []  # a new file: nothing to say
    target = tmp_path / "robot.aion"
    target.write_bytes(maps.full.read_bytes())  # another map already there
    result = run("compact", maps.full, "-o", target)
    assert result.exit_code == 0, result.stderr
    assert "note: robot.aion existed and is replaced" in result.stderr
    assert read_manifest(target)["query_only"]["from"]["name"] == maps.full.name
    again = run_json("compact", maps.full, "-o", target, "--format", "json")
    assert again["notes"] == ["robot.aion existed and is replaced"]


def test_a_map_of_one_day_is_not_called_smaller(tmp_path: Path) -> None:
    """A map of the short office log has no day of history closed for scoring, so the Fourier
    sums compact leaves out hold almost nothing: the copy is about the map's size, yet the
    summary said "(1.0x smaller)" and the docs "several times smaller". It now says "about the
    same size" and why; the 21-day map above still reads "x smaller"."""
    log = tmp_path / "day.mcap"
    write_office_log(log)
    full = tmp_path / "day.aion"
    assert run("build", log, "-o", full, "-q").exit_code == 0
    out = tmp_path / "robot.aion"
    result = run("compact", full, "-o", out)
    assert result.exit_code == 0, result.stderr
    ratio = full.stat().st_size / out.stat().st_size
    assert ratio < 1.05  # measured here, from the two files
    text = " ".join(result.stderr.split())
    assert "x smaller" not in text
    assert "(about the same size)" in text
    assert "days of history closed for scoring" in text
