"""``aion.Map.from_state(mapper.state).save(path)``, README's way to save a map fed in memory:
the saved map must say what it holds (``aion info``: "detections used 360 of 360", not "0 of
0") and a zone it records must be one every command can read (an unknown name was stored,
and every query of the saved map then failed with "unknown time zone")."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.types import DetectionBatch
from aion_cli.errors import InputError
from tests.cli.conftest import run_json

T0 = 1_767_607_200 * 10**9  # 2026-01-05 10:00 UTC


def _converted(tmp_path: Path, t: np.ndarray, x: np.ndarray, *options: str) -> Path:
    """One track walking along x at times ``t``, written as a tracks CSV and converted to a
    log (``aion convert`` with ``options``)."""
    from tests.cli.conftest import run

    csv = tmp_path / "tracks.csv"
    rows = [f"{int(ti)},1,{xi:.6f},0,0,0,1" for ti, xi in zip(t, x, strict=True)]
    csv.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n" + "\n".join(rows) + "\n")
    log = tmp_path / "tracks.mcap"
    assert run("convert", csv, "-o", log, *options).exit_code == 0
    return log


def _fed() -> Mapper:
    m = Mapper(ModelConfig())
    t = T0 + np.arange(0, 3600, 10) * 10**9
    n = len(t)
    m.set_fixed_sensor(int(t[0]), int(t[-1]))
    xyz = np.c_[np.linspace(0, 5, n), np.zeros(n), np.zeros(n)]
    xyz[:3] = np.nan  # three dropped, as a build drops them
    m.add_detections(DetectionBatch.from_arrays(t, xyz, np.zeros(n), np.ones(n)))
    return m


def test_a_saved_in_memory_map_counts_its_detections(tmp_path: Path) -> None:
    mapper = _fed()
    path = aion.Map.from_state(mapper.state, timezone="UTC").save(tmp_path / "mem.aion")
    counts = run_json("info", path, "--format", "json")["counts"]
    # before: no "read" / "used" (info: "detections used 0 of 0")
    assert (counts["read"], counts["used"]) == (360, 357)
    assert sum(counts["dropped"].values()) == 3
    assert aion.Map.load(path).manifest.counts["used"] == mapper.state.accepted == 357


def test_an_unknown_zone_is_refused_before_it_is_saved() -> None:
    with pytest.raises(InputError, match="unknown time zone 'Mars/Olympus'"):
        aion.Map.from_state(_fed().state, timezone="Mars/Olympus")


def test_an_in_memory_map_notes_what_its_saved_copy_notes(tmp_path: Path) -> None:
    """The map fed 10:00-11:00 on one day: before, in memory it listed no observed hours
    (``hour_observed`` None) and noted nothing, while its saved copy said 03:00 was never
    observed and that one day scores nothing."""
    mem = aion.Map.from_state(_fed().state, timezone="UTC")
    saved = aion.Map.load(mem.save(tmp_path / "mem.aion"))
    for m in (mem, saved):
        assert m.predict("2026-01-05 10:30").hour_observed is True
        night = m.predict("2026-01-05 03:00")
        assert night.hour_observed is False
        assert len(night.notes) == 2
        assert night.notes[0].startswith("every entry forecasts its static rate")
        assert "the map has 0 scored days" in night.notes[0]
        # the span fed, 10:00 .. 10:59:50, recorded as a build records its logs': 7 hours
        # before it is within the week either side that says nothing
        assert night.notes[1].startswith("no log observed 03:00-04:00 (UTC) on any day")
        assert "(the map observed 10:00-11:00)" in night.notes[1]
        (early,) = [n for n in m.predict("2025-12-25 03:00").notes if "map's data" in n]
        assert early == "this time is 11 days before the map's data (2026-01-05)"
        series = m.predict_series("2026-01-05 09:00", "2026-01-05 11:00", "1h", top=1)
        assert series.hour_observed == (False, True, False)  # fed 10:00:00 .. 10:59:50
    assert mem.manifest.counts["used"] == saved.manifest.counts["used"] == 357
    assert mem.manifest.families["observed_bins"] == saved.manifest.families["observed_bins"]


def test_a_saved_in_memory_map_records_the_span_a_log_built_map_records(tmp_path: Path) -> None:
    """The same detections fed in memory and written as a log then built: the map built
    records its log's span (first to last message) and its queries five weeks later say
    "5 weeks after the map's data"; the map from the state recorded no span, so neither it
    nor its saved copy said so. Both now record the state's first and last detection."""

    t = T0 + np.arange(0, 3600, 10) * 10**9
    x = np.linspace(0, 5, len(t))
    log = _converted(tmp_path, t, x)
    built = aion.build(log, tmp_path / "built.aion", tz="UTC")
    assert (built.manifest.start_ns, built.manifest.end_ns) == (int(t[0]), int(t[-1]))

    mapper = Mapper(ModelConfig())
    n = len(t)
    mapper.add_detections(
        DetectionBatch.from_arrays(t, np.c_[x, np.zeros(n), np.zeros(n)], np.zeros(n), np.ones(n))
    )
    mem = aion.Map.from_state(mapper.state, timezone="UTC")
    saved = aion.Map.load(mem.save(tmp_path / "mem.aion"))
    later = "2026-02-09 10:30"  # five weeks after Monday 2026-01-05
    said = [n for n in built.predict(later).notes if "after the map's data" in n]
    assert said == ["this time is 5 weeks after the map's data (2026-01-05)"]  # static rates
    for m in (mem, saved):
        assert (m.manifest.start_ns, m.manifest.end_ns) == (int(t[0]), int(t[-1]))
        assert [n for n in m.predict(later).notes if "after the map's data" in n] == said


def test_a_fixed_sensor_fed_in_memory_is_the_map_its_log_builds(tmp_path: Path) -> None:
    """A fixed sensor recording 10:00-11:00 whose detections stop at 10:20 (its tracker
    publishes empty messages after): ``aion build`` of its log counts the six windows
    observed, the last four empty, as it advances to the log's end. The same detections fed
    to a Mapper declared watching 10:00-11:00 and wrapped by ``Map.from_state`` counted two
    (the windows up to the last detection: the later ones were never closed) unless the
    Mapper was advanced by hand; now the saved map holds the same state members as the
    built one, and its manifest the same span and counts. The Mapper's own state is not
    advanced: it still takes a detection at 10:30."""
    import zipfile

    from tests.cli.conftest import run

    t = T0 + np.arange(0, 1200, 10) * 10**9
    x = np.linspace(0, 5, len(t))
    hour = f"{T0 // 10**9}..{T0 // 10**9 + 3600}"
    log = _converted(tmp_path, t, x, "--observed", hour)
    built = tmp_path / "built.aion"
    result = run("build", log, "-o", built, "--tz", "UTC", "-q")
    assert result.exit_code == 0, result.stderr

    mapper = Mapper(ModelConfig())
    mapper.set_fixed_sensor(T0, T0 + 3600 * 10**9)
    n = len(t)
    xyz = np.c_[x, np.zeros(n), np.zeros(n)]
    mapper.add_detections(DetectionBatch.from_arrays(t, xyz, np.zeros(n), np.ones(n)))
    open_window = mapper.state.open_window
    mem = aion.Map.from_state(mapper.state, timezone="UTC").save(tmp_path / "mem.aion")

    with zipfile.ZipFile(built) as a, zipfile.ZipFile(mem) as b:
        assert sorted(a.namelist()) == sorted(b.namelist())
        differ = [m for m in a.namelist() if m != "manifest.json" and a.read(m) != b.read(m)]
    assert differ == []
    one, two = aion.Map.load(built).manifest, aion.Map.load(mem).manifest
    assert (one.start_ns, one.end_ns) == (two.start_ns, two.end_ns) == (T0, T0 + 3600 * 10**9 - 1)
    assert one.counts["windows"] == two.counts["windows"] == 6
    assert {k: two.counts[k] for k in one.counts if k in two.counts} == {
        k: one.counts[k] for k in two.counts if k in one.counts
    }
    assert mapper.state.open_window == open_window
    later = DetectionBatch.from_arrays(np.array([T0 + 1800 * 10**9]), xyz[:1], np.zeros(1))
    assert mapper.add_detections(later)["before_window"] == 0  # accepted, not dropped
    assert mapper.state.accepted == n + 1
