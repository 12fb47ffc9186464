"""The Python API: docs/API.md's example runs as written, and its results equal the CLI's JSON
(the CLI formats the same functions); inputs of every accepted type; in-memory maps save."""

from __future__ import annotations

import contextlib
import json
import re
import shutil
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

import aion_cli as aion
from aion_cli.cli.main import cli
from tests.doc_blocks import run_blocks

REPO = Path(__file__).resolve().parents[1]
AT = "2026-01-12 08:40"


def _example() -> str:
    text = (REPO / "docs" / "API.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "docs/API.md has no python example"
    return blocks[0]


def _cli_json(*args: str | Path) -> Any:
    result = CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)


def _jsonable(value: Any) -> Any:
    """What the CLI's JSON makes of a value (non-finite floats are null there too)."""
    return json.loads(json.dumps(value, allow_nan=False))


@pytest.fixture(scope="module")
def example(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """docs/API.md's example, run in a folder holding the sample log; its variables."""
    folder = tmp_path_factory.mktemp("api")
    (folder / "samples").mkdir()
    shutil.copy(REPO / "samples" / "office.mcap", folder / "samples" / "office.mcap")
    scope = run_blocks(folder, "docs/API.md", _example())
    scope["folder"] = folder
    return scope


def test_the_example_builds_and_saves_a_map(example: dict[str, Any]) -> None:
    folder: Path = example["folder"]
    m = example["m"]
    assert isinstance(m, aion.Map)
    assert (folder / "office.aion").is_file()
    assert (folder / "copy.aion").read_bytes() == (folder / "office.aion").read_bytes()
    built = aion.Map.load(folder / "copy.aion")
    assert built.predict(AT, tz="UTC").records() == m.predict(AT, tz="UTC").records()


def test_a_build_report_s_repr_is_one_line(example: dict[str, Any]) -> None:
    """``built.report`` in a notebook: one line of what the build did, as a table's repr is.
    Before, the dataclass printed every field, each input's sha256 and per-topic decoding
    counts among them (3 kB for one log, growing with every log of a fleet)."""
    report = example["built"].report
    doc = report.to_dict()  # aion build --format json
    text = repr(report)
    assert "\n" not in text
    assert report.inputs[0]["sha256"] not in text
    used, read = doc["detections"]["used"], doc["detections"]["read"]
    assert text.startswith(f"<aion.BuildReport {doc['map']}: {used:,} of {read:,} detections used")
    assert f"from 1 log; {doc['nodes']:,} nodes, {doc['cells']:,} cells" in text
    assert f"{doc['windows']:,} windows" in text


def test_a_loaded_map_reads_what_queries_read(example: dict[str, Any]) -> None:
    """Map.load reads the map as the query commands do, without the per-entry Fourier sums
    that only learning needs (most of a full map's bytes: a 10^5-entry map took 866 MB
    through the API against 47 MB through the CLI), and answers exactly as a full read."""
    from aion_cli.mapquery import load_map

    path: Path = example["folder"] / "office.aion"
    light = aion.Map.load(path)
    assert not light.state.temporal.fourier_loaded
    full = aion.Map(load_map(path), path)
    assert full.state.temporal.fourier_loaded
    assert light.predict(AT, tz="UTC").records() == full.predict(AT, tz="UTC").records()
    assert light.predict(tz="UTC").records() == full.predict(tz="UTC").records()


def test_predict_equals_the_cli_json(example: dict[str, Any]) -> None:
    folder: Path = example["folder"]
    t = example["t"]
    cli = _cli_json(
        "predict", folder / "office.aion", "--time", AT, "--tz", "UTC", "--top", "5",
        "--format", "json",
    )
    assert len(t) == 5
    assert _jsonable(t.records()) == cli["entries"]
    assert (t.time_ns, t.time, t.zone, t.bins) == (cli["time_ns"], cli["time"], "UTC", cli["bins"])
    history = example["history"]
    cli_hist = _cli_json("predict", folder / "office.aion", "--historical", "--format", "json")
    assert _jsonable(history.records()) == cli_hist["entries"]
    assert history.time_ns is None
    doc = t.to_dict()
    assert {k: v for k, v in _jsonable(doc).items() if k != "map"} == {
        k: v for k, v in cli.items() if k != "map"
    }


def test_plan_equals_the_cli_json(example: dict[str, Any]) -> None:
    folder: Path = example["folder"]
    p = example["p"]
    cli = _cli_json(
        "plan", folder / "office.aion", "--from", "p103", "--to", "p2", "--time", AT,
        "--tz", "UTC", "--format", "json",
    )
    assert _jsonable(p.to_dict()) == {k: v for k, v in cli.items() if k != "map"}
    assert p.nodes[0] == "p103"
    assert p.nodes[-1] == "p2"
    assert p.distance_only is not None
    assert p.distance_only.length_m <= p.length_m + 1e-9  # the shortest is never longer
    assert p.cost <= p.distance_only.cost + 1e-9  # the temporal plan is never costlier


def test_departures_series_and_graph_equal_the_cli(example: dict[str, Any]) -> None:
    folder: Path = example["folder"]
    office = folder / "office.aion"
    leave = _cli_json(
        "plan", office, "--from", "kitchen", "--to", "office 1", "--tz", "UTC", "--leave",
        "2026-01-12 07:00..2026-01-12 10:00", "--step", "30m", "--format", "json",
    )
    assert _jsonable(example["best"].to_dict()) == {k: v for k, v in leave.items() if k != "map"}
    series = _cli_json(
        "predict", office, "--layer", "rooms", "--tz", "UTC", "--from", "2026-01-12 06:00",
        "--to", "2026-01-12 20:00", "--step", "1h", "--format", "json",
    )
    day = example["day"]
    assert _jsonable(day.records()) == series["entries"]
    assert day.flow.shape == (len(series["entries"]), 15)
    document = _jsonable(day.to_dict())  # the whole document, its times, zone and hours
    assert {k: v for k, v in document.items() if k != "map"} == {
        k: v for k, v in series.items() if k != "map"
    }
    assert document["times"][0] == "2026-01-12 06:00:00+00:00"
    assert len(document["hour_observed"]) == 15
    (graph,) = example["graph"]
    assert graph == Path("office-4d.json")
    assert (folder / graph).stat().st_size > 0


def test_export_writes_what_the_cli_writes(example: dict[str, Any], tmp_path: Path) -> None:
    folder: Path = example["folder"]
    files = example["files"]
    out = folder / "office-export"
    written = sorted(p for p in out.rglob("*") if p.is_file() and p.name != ".aion-export.json")
    assert sorted(folder / f for f in files) == written
    cli_out = tmp_path / "cli"
    result = CliRunner().invoke(
        cli,
        ["export", str(folder / "office.aion"), "--time", AT, "--tz", "UTC", "-o", str(cli_out),
         "--path-from", "p103", "--path-to", "p2"],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.stderr
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in cli_out.iterdir())
    for name in ("entries.csv", "scene.ply", "nodes.ply"):
        assert (out / name).read_bytes() == (cli_out / name).read_bytes(), name
    ours = json.loads((out / "entries.json").read_text())
    theirs = json.loads((cli_out / "entries.json").read_text())
    assert ours["entries"] == theirs["entries"]


def test_times_of_every_accepted_type_agree(example: dict[str, Any]) -> None:
    m = example["m"]
    ns = aion.to_ns(AT, m._zone("UTC"))
    assert ns == aion.to_ns(datetime(2026, 1, 12, 8, 40, tzinfo=UTC), m._zone(None))
    assert ns == aion.to_ns(datetime(2026, 1, 12, 8, 40), m._zone("UTC"))  # naive: in the zone
    by_text = m.predict(AT, tz="UTC", top=3).records()
    assert m.predict(ns, top=3).records() == by_text
    assert m.predict(datetime(2026, 1, 12, 8, 40, tzinfo=UTC), top=3).records() == by_text


def test_bad_inputs_are_typed_errors(example: dict[str, Any], tmp_path: Path) -> None:
    from aion_cli.errors import MapFileError, UnknownNodeError
    from aion_cli.timeparse import TimeFormatError

    m = example["m"]
    with pytest.raises(TimeFormatError):
        m.predict("2300-01-01")
    with pytest.raises(aion.InputError, match="unknown layer"):
        m.predict(AT, layer="floors")
    with pytest.raises(UnknownNodeError):
        m.plan("p99999", "p2", time=AT)
    # a mistyped room is named as a room, with the map's rooms as the hint (not its places)
    with pytest.raises(UnknownNodeError, match="room R99 is not in the map") as unknown:
        m.plan("R99", "p2", time=AT)
    assert unknown.value.hint.startswith("its rooms: R")
    with pytest.raises(MapFileError):
        aion.Map.load(tmp_path / "missing.aion")
    notes = tmp_path / "notes.txt"
    notes.write_text("mine")
    with pytest.raises(aion.InputError):
        m.save(notes)  # never replaces a file that is not a map
    assert notes.read_text() == "mine"
    for call in (  # an empty path is never the current folder
        lambda: aion.build([""], output=tmp_path / "x.aion"),
        lambda: aion.build(["samples/office.mcap"], output=""),
        lambda: aion.Map.load(""),
        lambda: m.save(""),
        lambda: m.export("", time=AT),
        lambda: aion.merge(["", ""], tmp_path / "y.aion"),
    ):
        with pytest.raises(aion.InputError, match="an empty path"):
            call()
    assert not (tmp_path / "x.aion").exists()
    with pytest.raises(aion.InputError, match="takes a loaded map"):  # a path where a map goes
        aion.Map("office.aion")  # type: ignore[arg-type]
    with pytest.raises(aion.InputError, match=r"^file writes a \.png file"):  # the API's name
        m.picture(tmp_path / "map.jpg")


def test_an_in_memory_state_is_saved_and_reloads_equal(tmp_path: Path) -> None:
    """A Mapper fed in memory (no log, no build) saves through the API; the file predicts
    what the state predicts."""
    import numpy as np

    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch

    t0 = 1_767_600_000 * 10**9  # 2026-01-05 08:00 UTC
    n = 400
    rng = np.random.default_rng(3)
    mapper = Mapper(ModelConfig())
    t = t0 + np.sort(rng.integers(0, 4 * 3600 * 10**9, n))
    xyz = np.column_stack([rng.uniform(0, 4, n), rng.uniform(0, 2, n), np.zeros(n)])
    batch = DetectionBatch.from_arrays(t_ns=t, xyz=xyz, heading=rng.uniform(-np.pi, np.pi, n))
    mapper.set_fixed_sensor(t0, t0 + 4 * 3600 * 10**9)
    mapper.add_detections(batch)
    mapper.advance(t0 + 4 * 3600 * 10**9)
    m = aion.Map.from_state(mapper.state, timezone="UTC")
    at = t0 + 2 * 3600 * 10**9
    # not saved yet: one label names it everywhere a file's path would (was "<memory>" in a
    # table, "in memory" in the map's repr)
    table, series = m.predict(at), m.predict_series(at, at + 3600 * 10**9)
    assert table.map == series.map == table.to_dict()["map"] == series.to_dict()["map"]
    assert table.map == "<memory>"
    assert repr(m).startswith("<aion.Map <memory>: ")
    assert repr(table).startswith("<aion.Table <memory> at ")
    assert repr(series).startswith("<aion.SeriesTable <memory>: ")
    saved = m.save(tmp_path / "memory.aion")
    again = aion.Map.load(saved)
    assert again.predict(at).records() == m.predict(at).records()
    assert m.predict(at).map == str(saved)  # saved, it is named by its file
    assert again.manifest.graph_source == "memory"
    assert again.timezone == "UTC"
    # its repr counts the live entries (the cells the 400 detections fell in), not the
    # table's reserved rows
    cells = len({tuple(k) for k in np.floor(xyz[:, :2] / 0.5).astype(int).tolist()})
    assert repr(again) == f"<aion.Map {saved}: {cells:,} entries>"
    empty = aion.Map.from_state(Mapper(ModelConfig()).state, timezone="UTC")
    assert repr(empty) == "<aion.Map <memory>: 0 entries>"


def test_a_table_says_whether_its_hour_was_observed(tmp_path: Path) -> None:
    """A fixed sensor's 20 minutes from 08:00 UTC: 08:30 was observed, 03:00 was not; the
    table's to_dict is the CLI's document, flag included."""
    from tests.cli.logdata import write_office_log

    log = tmp_path / "morning.mcap"
    write_office_log(log, graph=False, tf=False)
    m = aion.build([log], output=tmp_path / "morning.aion")
    assert m.predict("2026-11-24 08:30", tz="UTC").hour_observed is True
    night = m.predict("2026-11-24 03:00", tz="UTC")
    assert night.hour_observed is False
    cli = _cli_json("predict", tmp_path / "morning.aion", "--time", "2026-11-24 03:00", "--tz",
                    "UTC", "--format", "json")
    assert cli["hour_observed"] is False
    assert _jsonable(night.to_dict())["hour_observed"] is False
    assert m.predict(historical=True).hour_observed is None


def test_the_api_s_input_errors_carry_a_hint(example: dict[str, Any]) -> None:
    """As the CLI's: a wrong type or value says what to give instead (top=2.5 and
    workers="2" had no hint)."""
    m = example["m"]
    for call in (
        lambda: m.predict(AT, top=2.5),
        lambda: m.predict(AT, top=0),
        lambda: m.predict(AT, nodes=3.5),
        lambda: m.predict(True),
        lambda: aion.build(["x.mcap"], workers="2"),
        lambda: aion.build(42),
        lambda: m.plan("p1", "p2", time=AT, speed=float("nan")),
        # these had none: the CLI's same mistakes have one
        lambda: m.predict(AT, historical=True),
        lambda: m.picture("x.png", time=AT, historical=True),
        lambda: m.predict(AT, nodes=["p1"], at=(1.0, 2.0)),
        lambda: m.plan("p1", "p2", time=AT, leave=(AT, AT)),
        lambda: m.plan(None, "p2"),
        lambda: aion.Map.load(123),
        lambda: m.save(b"copy.aion"),
        lambda: m.holdout("later.mcap", radius="1"),
        lambda: aion.build(["x.mcap"], config={"max_order": 99}),
    ):
        with pytest.raises(aion.InputError) as exc:
            call()
        assert exc.value.hint, exc.value.message


def test_a_bad_step_is_named_as_the_api_takes_it(example: dict[str, Any]) -> None:
    """``step="0s"`` / ``"5x"`` were answered in the command line's words ("--step must be
    at least 1 s", hint "e.g. --step 1h"): the API names its own argument and form."""
    m = example["m"]
    for step, said in (("0s", "step must be at least 1 s"), ("5x", "unknown unit 'x' in step")):
        with pytest.raises(aion.InputError) as exc:
            m.predict_series("2026-01-12 06:00", "20:00", step, tz="UTC")
        assert said in exc.value.message
        assert "--step" not in exc.value.message + str(exc.value.hint)
    with pytest.raises(aion.InputError) as exc:
        m.predict_series("2026-01-12 06:00", "20:00", "0s", tz="UTC")
    assert exc.value.hint is not None
    assert "step='1h'" in exc.value.hint


def test_a_spans_end_given_as_a_clock_counts_from_its_start(example: dict[str, Any]) -> None:
    """``leave=("2026-01-12 07:00", "10:00")`` and ``predict_series(..., "20:00")`` end that
    day, as ``--leave START..END`` and ``--from`` / ``--to`` read them (alone, ``"10:00"``
    is today's)."""
    m = example["m"]
    best = m.plan("kitchen", "office 1", leave=("2026-01-12 07:00", "10:00"), step="30m",
                  tz="UTC")
    assert best.to_dict() == example["best"].to_dict()
    day = m.predict_series("2026-01-12 06:00", "20:00", "1h", tz="UTC", layer="rooms")
    assert day.to_dict() == example["day"].to_dict()
    relative = m.predict_series("2026-01-12 06:00", "+14h", "1h", tz="UTC", layer="rooms")
    assert relative.times_ns == example["day"].times_ns


def test_a_series_export_and_picture_write_what_the_cli_writes(
    example: dict[str, Any], tmp_path: Path
) -> None:
    """``aion export --from --to --step`` (the demo's MCAP of the day, a folder per time, a
    picture of small multiples) had no API: ``Map.export`` and ``Map.picture`` took one time.
    With ``series=(start, end)`` and ``step`` they write the command's bytes."""
    folder: Path = example["folder"]
    office, m = folder / "office.aion", example["m"]
    (scene,) = example["scene"]  # docs/API.md's example: the day as one MCAP file
    span = ["--from", "2026-01-12 06:00", "--to", "2026-01-12 20:00", "--tz", "UTC"]

    def cli_export(out: Path, *args: str) -> None:
        with contextlib.chdir(folder):  # the map named as the example names it: its metadata
            result = CliRunner().invoke(
                cli, ["export", office.name, *span, *args, "-o", str(out)], catch_exceptions=False
            )
        assert result.exit_code == 0, result.stderr

    cli_export(tmp_path / "day.mcap", "--step", "1h", "--format", "mcap", "--path-from", "p103",
               "--path-to", "p2")
    assert (folder / scene).read_bytes() == (tmp_path / "day.mcap").read_bytes()
    cli_export(tmp_path / "day.png", "--step", "2h", "--format", "png")
    png = m.picture(folder / "day.png", series=("2026-01-12 06:00", "20:00"), step="2h", tz="UTC")
    assert png.read_bytes() == (tmp_path / "day.png").read_bytes()
    cli_export(tmp_path / "frames", "--step", "7h")  # 06:00, 13:00, 20:00
    files = m.export(folder / "frames", series=("2026-01-12 06:00", "20:00"), step="7h", tz="UTC")
    frames = sorted(p.name for p in (folder / "frames").iterdir() if p.is_dir())
    assert frames == ["20260112T060000Z", "20260112T130000Z", "20260112T200000Z"]
    assert frames == sorted(p.name for p in (tmp_path / "frames").iterdir() if p.is_dir())
    for frame in frames:
        ours, theirs = folder / "frames" / frame, tmp_path / "frames" / frame
        assert sorted(p.name for p in ours.iterdir()) == sorted(p.name for p in theirs.iterdir())
        assert (ours / "scene.ply").read_bytes() == (theirs / "scene.ply").read_bytes()
        assert ours / "entries.csv" in files


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda m: m.export("x/", time=AT, series=(AT, "20:00")), "choose time or series"),
        (lambda m: m.picture("x.png", historical=True, series=(AT, "20:00")),
         "choose historical=True or series"),
        (lambda m: m.export("x/", step="1h"), "step needs series"),
        (lambda m: m.export("x.json", series=(AT, "20:00")), "a scene-graph file holds one time"),
        (lambda m: m.export("x.ply", series=(AT, "20:00")), "one ply scene per time into a folder"),
        (lambda m: m.picture("x.png", series=(AT, "2026-01-12 08:40")), None),  # one time: fine
        (lambda m: m.picture("x.png", series=("2026-01-12 00:00", "2026-01-13 06:00"), tz="UTC"),
         "the picture would have 31 panels"),
    ],
)
def test_a_series_is_refused_where_it_cannot_be(
    example: dict[str, Any], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, call: Any,
    message: str | None,
) -> None:
    monkeypatch.chdir(tmp_path)
    if message is None:
        assert call(example["m"]) == Path("x.png")
        return
    with pytest.raises(aion.InputError, match=message) as caught:
        call(example["m"])
    if "panels" in message:  # the hint in the API's words: step=, series (not --step, --from)
        assert caught.value.hint == 'step="2h" draws this span in 16 panels (or shorten series)'
