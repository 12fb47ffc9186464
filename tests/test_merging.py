"""Merging map files (:mod:`aion_cli.merging`): exactness against one build, conservation of
counts in either lineage, the different-session release and re-bind, provenance, bad inputs.

Maps are built in memory with the engine's Mapper (the logs of tests/engine/state_logs.py) and
written as map files with a manifest naming their (made-up) logs (tests/merging_logs.py), so
every rule of the file layer is exercised without decoding a log; tests/cli/test_merge.py does
the same from real logs through the command line."""

from __future__ import annotations

import hashlib
import json
import re
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.compare import pending_sorted, plain
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.state import MapState
from aion_cli.errors import ConfigError, InputError, MapFileError
from aion_cli.formats.mapfile import read_manifest
from aion_cli.manifest import Manifest
from aion_cli.mapquery import load_map
from aion_cli.merging import merge_map_files
from tests.doc_blocks import run_blocks
from tests.engine.engine_builders import (
    T0,
    S,
    check_invariants,
    closed_counts,
    detections,
    graph,
    pending_counts,
    pid,
)
from tests.engine.state_logs import CFG, DAY, W, fixed_sensor_log, robot_log, run_steps
from tests.merging_logs import fixed_sensor_map, input_logs, log_span, random_log, save_map


def _entry_sums(state: MapState) -> tuple[float, float, float]:
    """Σ over live entries of directed + undirected counts, of speed samples, of speed sums."""
    e, rows = state.entries, state.entries.live_rows()
    return (
        float(e.counts[rows].sum() + e.nodir[rows].sum()),
        float(e.speed_n[rows].sum()),
        float(e.speed_sum[rows].sum()),
    )


# -- same lineage: exact ----------------------------------------------------------------------


def test_merging_two_map_files_equals_building_from_both_logs(tmp_path: Path) -> None:
    """merge(map(A), map(B)) == build(A, B), every member compared (ints exactly, floats to
    rtol 1e-12), under the conditions in which engine.merge.merge_maps is exact:

    * the logs are disjoint in time and on different days (B starts two days after A), so no
      window is shared and no day is split between the maps (approximation 4);
    * both logs see the same graph (same node ids at the same positions: one lineage) and
      touch the same places from their first window on (``spots``), so no entry exists in one
      map only (approximation 1) and no node moves between them (approximation 3);
    * A's map holds one day and B's day is pending: the only day closed is A's, against the
      same (empty) history in both, so no day-ahead score differs (approximation 2).
    """
    spots = np.c_[np.random.default_rng(9).uniform(-1, 8, (40, 2)), np.zeros(40)]
    a_steps = fixed_sensor_log(T0, seed=4, spots=spots)
    b_steps = fixed_sensor_log(T0 + 2 * DAY, seed=5, spots=spots)
    both = run_steps(a_steps + b_steps).state
    a = save_map(run_steps(a_steps).state, tmp_path / "a.aion", ("a.mcap",), log_span(T0))
    b = save_map(run_steps(b_steps).state, tmp_path / "b.aion", ("b.mcap",), log_span(T0 + 2 * DAY))
    report = merge_map_files([b, a], tmp_path / "ab.aion")  # any order: sorted by time
    assert report.lineage == "same"
    assert report.lineage_reason == "5 of 5 shared node ids lie within 1 m"
    assert [i.file.name for i in report.inputs] == ["a.aion", "b.aion"]
    merged = load_map(tmp_path / "ab.aion", writable=True).state
    check_invariants(merged)
    xa, ma = both.to_arrays()
    xm, mm = merged.to_arrays()
    assert mm == ma
    pa, pm = pending_sorted(plain(xa)), pending_sorted(plain(xm))
    assert sorted(pa) == sorted(pm)
    # the fixed-sensor intervals of both maps (the merged map had kept the later map's only,
    # so its manifest described the later map's windows alone)
    for name in ("obs_fixed_start", "obs_fixed_end"):
        np.testing.assert_array_equal(np.sort(pm[name]), np.sort(pa[name]), err_msg=name)
    for name in pa:
        assert pa[name].dtype == pm[name].dtype, name
        if pa[name].dtype.kind in "fc":
            np.testing.assert_allclose(pm[name], pa[name], rtol=1e-12, atol=0, err_msg=name)
        else:
            np.testing.assert_array_equal(pm[name], pa[name], err_msg=name)
    assert len(pa["redirect_keys"]) > 0
    assert np.any(pa["entry_kind"] == 0)
    assert pa["temporal_glob_n"][0] == 6  # A's day is closed (B's is pending), in both
    assert report.notes == []  # no approximation applied


def test_the_output_manifest_accounts_for_every_log_and_map(tmp_path: Path) -> None:
    a = fixed_sensor_map(tmp_path / "a.aion", ("a1.mcap", "a2.mcap"), T0, seed=1)
    b = fixed_sensor_map(tmp_path / "b.aion", ("b.mcap",), T0 + DAY * 3, seed=2)
    report = merge_map_files([a, b], tmp_path / "out.aion")
    doc = read_manifest(tmp_path / "out.aion")
    manifest = Manifest.from_dict(doc)
    assert [i.name for i in manifest.inputs] == ["a1.mcap", "a2.mcap", "b.mcap"]
    assert [i.sha256 for i in manifest.inputs] == [
        i.sha256 for i in input_logs("a1.mcap", "a2.mcap") + input_logs("b.mcap")
    ]
    assert (manifest.start_ns, manifest.end_ns) == (T0, T0 + 3 * DAY + 6 * W)
    accepted = load_map(a).state.accepted + load_map(b).state.accepted
    assert manifest.counts["read"] == manifest.counts["used"] == accepted == report.detections
    assert manifest.counts["dropped"] == {"nan": 0}
    assert manifest.counts["nodes"] == 5
    assert manifest.timezone == "UTC"
    assert set(manifest.families) == {
        "flow", "direction", "reconciled", "scored_windows", "scored_days",
        "last_day_provisional", "observed_bins", "rules", "calendar",
    }
    # the merged map observed the hours either input observed, and no other
    inputs = [read_manifest(p)["families"]["observed_bins"] for p in (a, b)]
    assert manifest.families["observed_bins"] == sorted(set(inputs[0]) | set(inputs[1]))
    assert inputs[0]
    assert inputs[1]
    files = {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in (a, b)}
    assert [(m["name"], m["sha256"]) for m in doc["merged_from"]] == list(files.items())
    assert doc["lineage"] == "same"
    assert not (tmp_path / "out.aion.lock").exists()


# -- counts are conserved in either lineage ---------------------------------------------------


@settings(max_examples=25, deadline=None)
@given(
    seeds=st.lists(st.integers(0, 2**31), min_size=2, max_size=3),
    gaps=st.lists(st.integers(1, 4), min_size=3, max_size=3),
    windows=st.integers(1, 8),
    lineage=st.sampled_from(["auto", "same", "different"]),
    sessions=st.booleans(),
)
def test_counts_are_conserved_through_any_merge(
    seeds: list[int], gaps: list[int], windows: int, lineage: str, sessions: bool
) -> None:
    """Σ counts, Σ speed samples and the detections accepted of the merged map are the sums of
    the inputs', in the same lineage and across sessions (each map's graph a new session:
    node ids p0.. at random positions), and the temporal model holds every detection once."""
    with tempfile.TemporaryDirectory() as folder:
        paths, sums = [], np.zeros(3)
        start, accepted = T0, 0
        for k, seed in enumerate(seeds):
            rng = np.random.default_rng(seed)
            nodes = (
                np.c_[rng.uniform(-1, 8, (5, 2)), np.zeros(5)]
                if sessions
                else np.array([[0, 0, 0], [3, 0, 0], [0, 3, 0], [3, 3, 0], [6, 6, 0.0]])
            )
            state = run_steps(random_log(start, seed, windows, nodes)).state
            sums += _entry_sums(state)
            accepted += state.accepted
            paths.append(
                save_map(state, Path(folder) / f"m{k}.aion", (f"log{k}",), log_span(start, windows))
            )
            start += gaps[k] * DAY
        report = merge_map_files(paths, Path(folder) / "out.aion", lineage=lineage)
        merged = load_map(Path(folder) / "out.aion", writable=True).state
    check_invariants(merged)  # Σ entries == accepted == Σ temporal (closed + pending + open)
    assert merged.accepted == accepted == report.detections
    got = _entry_sums(merged)
    assert got[:2] == (sums[0], sums[1])  # integer-valued: exact
    assert got[2] == pytest.approx(sums[2], rel=1e-12)
    if lineage != "auto":
        assert report.lineage == lineage
    elif not sessions:
        assert report.lineage == "same"


# -- different sessions: released and re-bound ------------------------------------------------

#: Two sessions: session A has p0 at (0.25, 0.25) and p1 at (10.25, 0.25); session B reuses the
#: ids, p0 at (20.25, 0.25) and p1 at (0.25, 0.25) (cell centres of the 0.5 m hash).
A_NODES = np.array([[0.25, 0.25, 0.0], [10.25, 0.25, 0.0]])
B_NODES = np.array([[20.25, 0.25, 0.0], [0.25, 0.25, 0.0]])


def _session(start: int, nodes: np.ndarray, spots: dict[tuple[float, float], int]) -> MapState:
    """A map of one session: its graph, a fixed sensor over two windows, ``n`` detections at
    each spot in the first window (after the nodes have been stable for 30 s)."""
    m = Mapper(CFG)
    m.set_fixed_sensor(start, start + 2 * W)
    m.add_graph(graph(start, [0, 1], nodes))
    xyz = [(x, y, 0.0) for (x, y), n in spots.items() for _ in range(n)]
    m.add_detections(detections(start + 60 * S, xyz))
    m.advance(start + 2 * W)
    return m.state


def _node_counts(state: MapState) -> dict[str, float]:
    rows = state.entries.node_rows()
    ids = state.entries.node_id[rows]
    labels = {int(pid(i)): f"p{i}" for i in range(2)}
    return {
        labels[int(i)]: float(state.entries.counts[r].sum()) for i, r in zip(ids, rows, strict=True)
    }


def test_maps_of_different_sessions_are_released_and_rebound(tmp_path: Path) -> None:
    """Known answer: every place of the target graph (B's, the newest) holds the detections
    near it from both maps, whatever node id held them in A; the rest stay hash cells."""
    a_state = _session(T0, A_NODES, {(0.3, 0.2): 5, (10.2, 0.3): 6, (20.3, 0.2): 3})
    b_state = _session(T0 + 2 * DAY, B_NODES, {(0.2, 0.3): 4, (20.2, 0.2): 2, (10.3, 0.2): 7})
    assert _node_counts(a_state) == {"p0": 5, "p1": 6}  # bound in A: p0 near (0, 0)
    assert _node_counts(b_state) == {"p0": 2, "p1": 4}  # in B, p1 is near (0, 0)
    a = save_map(a_state, tmp_path / "a.aion", ("a.mcap",), log_span(T0, 2))
    b = save_map(b_state, tmp_path / "b.aion", ("b.mcap",), log_span(T0 + 2 * DAY, 2))
    report = merge_map_files([a, b], tmp_path / "ab.aion")
    assert report.lineage == "different"
    assert report.lineage_reason.startswith("of the 2 node ids both a.aion and b.aion hold, 0")
    assert report.released == 4
    merged = load_map(tmp_path / "ab.aion", writable=True).state
    check_invariants(merged)
    assert _node_counts(merged) == {"p1": 5 + 4, "p0": 3 + 2}  # near (0, 0); near (20, 0)
    cells = merged.entries.cell_rows()
    assert merged.entries.counts[cells].sum() == 6 + 7  # near (10, 0): no place in B there
    assert merged.graph is not None
    np.testing.assert_array_equal(merged.graph.places.xyz, B_NODES)
    # the detections' windows follow them: A's day is closed, B's pending
    p1 = merged.node_entry_rows(pid([1]))
    assert closed_counts(merged, p1).sum() == 5
    assert pending_counts(merged)[p1].sum() == 4
    # and the ids alone would have put A's flow at B's unrelated places
    merge_map_files([a, b], tmp_path / "same.aion", lineage="same")
    wrong = _node_counts(load_map(tmp_path / "same.aion", writable=True).state)
    # (A's p1 at (10, 0) adds into B's p1 at (0, 0), and A's redirect of the cell at (10, 0)
    # to p1 pulls B's 7 detections there along; A's p0 at (0, 0) adds into B's p0 at (20, 0))
    assert wrong == {"p1": 4 + 6 + 7, "p0": 2 + 5 + 3}


def test_a_map_without_graph_beside_one_with_a_graph_binds_to_it(tmp_path: Path) -> None:
    cells_only = Mapper(CFG)
    cells_only.set_fixed_sensor(T0, T0 + W)
    cells_only.add_detections(detections(T0 + S, [[20.3, 0.2, 0.0]] * 3))
    cells_only.advance(T0 + W)
    a = save_map(cells_only.state, tmp_path / "a.aion", ("a.mcap",), log_span(T0, 1))
    b = save_map(
        _session(T0 + DAY, B_NODES, {(0.2, 0.3): 4}),
        tmp_path / "b.aion",
        ("b.mcap",),
        log_span(T0 + DAY, 2),
    )
    report = merge_map_files([a, b], tmp_path / "ab.aion")
    assert report.lineage == "different"
    assert report.lineage_reason.startswith("a.aion has no scene graph")
    assert _node_counts(load_map(tmp_path / "ab.aion", writable=True).state) == {"p0": 3, "p1": 4}


# -- provenance and bad input -----------------------------------------------------------------


@pytest.fixture
def two_maps(tmp_path: Path) -> tuple[Path, Path]:
    a = fixed_sensor_map(tmp_path / "a.aion", ("a.mcap",), T0, seed=1)
    b = fixed_sensor_map(tmp_path / "b.aion", ("b.mcap",), T0 + 2 * DAY, seed=2)
    return a, b


def test_a_log_in_two_maps_is_refused(tmp_path: Path) -> None:
    a = fixed_sensor_map(tmp_path / "a.aion", ("a.mcap", "shared.mcap"), T0, seed=1)
    b = fixed_sensor_map(tmp_path / "b.aion", ("shared.mcap",), T0 + 2 * DAY, seed=2)
    with pytest.raises(InputError, match=r"shared\.mcap .* in both a\.aion and b\.aion") as exc:
        merge_map_files([a, b], tmp_path / "out.aion")
    assert "never counted twice" in exc.value.message
    assert not (tmp_path / "out.aion").exists()
    assert not (tmp_path / "out.aion.lock").exists()


def test_the_same_map_twice_is_refused(two_maps: tuple[Path, Path], tmp_path: Path) -> None:
    a, _ = two_maps
    with pytest.raises(InputError, match="given twice"):
        merge_map_files([a, tmp_path / "." / "a.aion"], tmp_path / "out.aion")
    copy = tmp_path / "copy.aion"
    copy.write_bytes(a.read_bytes())
    with pytest.raises(InputError, match="are the same map"):
        merge_map_files([a, copy], tmp_path / "out.aion")


def test_bad_inputs_are_typed_errors(two_maps: tuple[Path, Path], tmp_path: Path) -> None:
    a, b = two_maps
    with pytest.raises(InputError, match="at least two maps"):
        merge_map_files([a], tmp_path / "out.aion")
    with pytest.raises(InputError, match="one of the input maps"):
        merge_map_files([a, b], a)
    with pytest.raises(InputError, match="not found"):
        merge_map_files([a, tmp_path / "missing.aion"], tmp_path / "out.aion")
    with pytest.raises(InputError, match="unknown lineage"):
        merge_map_files([a, b], tmp_path / "out.aion", lineage="maybe")
    text = tmp_path / "notes.txt"
    text.write_text("not a map")
    with pytest.raises(MapFileError):
        merge_map_files([a, text], tmp_path / "out.aion")
    with pytest.raises(MapFileError, match="not an aion map"):
        merge_map_files([a, b], text)  # never written over
    assert text.read_text() == "not a map"
    with pytest.raises(InputError, match="scene-graph file not found"):
        merge_map_files([a, b], tmp_path / "out.aion", graph_file=tmp_path / "nope.json")
    assert not (tmp_path / "out.aion").exists()


def test_maps_of_different_models_or_zones_are_refused(tmp_path: Path) -> None:
    a = fixed_sensor_map(tmp_path / "a.aion", ("a.mcap",), T0, seed=1)
    other = run_steps(
        fixed_sensor_log(T0 + 2 * DAY, seed=2), Mapper(CFG.replace(bind_radius=2.0))
    ).state
    b = save_map(other, tmp_path / "b.aion", ("b.mcap",), log_span(T0 + 2 * DAY))
    with pytest.raises(ConfigError, match=r"bind_radius 1\.0 vs 2\.0") as exc:
        merge_map_files([a, b], tmp_path / "out.aion")
    assert exc.value.hint is not None
    assert "config" in exc.value.hint
    c = fixed_sensor_map(
        tmp_path / "c.aion", ("c.mcap",), T0 + 2 * DAY, seed=2, timezone="Europe/Berlin"
    )
    with pytest.raises(ConfigError, match="different time zones"):
        merge_map_files([a, c], tmp_path / "out.aion")


def test_overlapping_maps_merge_with_a_note(tmp_path: Path) -> None:
    a = fixed_sensor_map(tmp_path / "a.aion", ("a.mcap",), T0, seed=1)
    b = fixed_sensor_map(tmp_path / "b.aion", ("b.mcap",), T0 + 3 * W, seed=2)
    report = merge_map_files([a, b], tmp_path / "out.aion")
    assert any("overlap" in n and "counts twice" in n for n in report.notes), report.notes
    assert any("approximation 4" in n for n in report.notes)  # and the same day twice
    # each map scored its days without the other's, though neither closed a day after the
    # other began: said (a merge of interleaved spans had no word on it)
    assert any("approximation 2" in n for n in report.notes)
    assert json.loads(json.dumps(report.to_dict()))["detections"] == report.detections


def test_the_notes_name_the_approximations_that_apply(tmp_path: Path) -> None:
    """Detections anywhere and a robot's later map (entries in one map only, whose empty
    windows that robot saw are not known: approximation 1; a fixed sensor's windows would
    be, tests/cli/test_merge_fixed_sensors.py), of two days, the first closed and scored on
    its own (approximation 2)."""
    a = fixed_sensor_map(tmp_path / "a.aion", ("a.mcap",), T0, seed=1)
    late = run_steps(robot_log(T0 + 2 * DAY, seed=2, days=2)).state
    b = save_map(late, tmp_path / "b.aion", ("b.mcap",), (T0 + 2 * DAY, T0 + 3 * DAY + 6 * W))
    notes = merge_map_files([a, b], tmp_path / "out.aion").notes
    assert [n for n in notes if "approximation" in n] == [
        next(n for n in notes if n.endswith("(merge approximation 1)")),
        next(n for n in notes if n.endswith("(merge approximation 2)")),
    ]


def test_configs_compare_as_parameters(tmp_path: Path) -> None:
    """A map and one built with an equal config (a fresh object) merge."""
    same = ModelConfig(window_s=600.0, stability_s=30.0)
    a = fixed_sensor_map(tmp_path / "a.aion", ("a.mcap",), T0, seed=1)
    b = fixed_sensor_map(
        tmp_path / "b.aion", ("b.mcap",), T0 + 2 * DAY, seed=2, mapper=Mapper(same)
    )
    assert merge_map_files([a, b], tmp_path / "out.aion").lineage == "same"


def test_the_api_merges_as_docs_api_md_shows(tmp_path: Path) -> None:
    """docs/API.md's merge example, run as written beside two maps of those names."""
    fixed_sensor_map(tmp_path / "monday.aion", ("mon.mcap",), T0, seed=1)
    fixed_sensor_map(tmp_path / "wednesday.aion", ("wed.mcap",), T0 + 2 * DAY, seed=2)
    text = (Path(__file__).resolve().parents[1] / "docs" / "API.md").read_text()
    block = next(b for b in re.findall(r"```python\n(.*?)```", text, flags=re.S) if "merge(" in b)
    scope = run_blocks(tmp_path, "docs/API.md", block)
    week = scope["week"]
    import aion_cli as aion
    from aion_cli.api import Map, compact, merge
    from aion_cli.merging import MergeReport

    assert isinstance(week, Map)
    assert isinstance(week.report, MergeReport)
    assert week.path == Path("week.aion")
    assert (tmp_path / "week.aion").is_file()
    assert week.report.lineage == "same"
    assert [i.name for i in week.manifest.inputs] == ["mon.mcap", "wed.mcap"]
    assert week.state.accepted == week.report.detections
    assert aion.merge is merge  # the top-level names
    assert aion.compact is compact
    # one path alone is one map, as aion.build takes one log (stop 70): a whole map alone is
    # refused as the command refuses it, not as a string that should have been a list
    with pytest.raises(InputError, match="a merge needs at least two maps"):
        aion.merge(str(tmp_path / "monday.aion"), tmp_path / "x.aion")
    assert not (tmp_path / "x.aion").exists()


def test_a_damaged_recording_windows_count_is_left_out_of_a_merge(tmp_path: Path) -> None:
    """An input map whose manifest holds ``counts.recording_windows = "ten"`` merges; the
    output leaves the count out rather than fail in ``int()`` (a map file is untrusted)."""
    import json
    import zipfile

    a = fixed_sensor_map(tmp_path / "a.aion", ("a1.mcap",), T0, seed=1)
    b = fixed_sensor_map(tmp_path / "b.aion", ("b.mcap",), T0 + DAY * 3, seed=2)
    damaged = tmp_path / "damaged.aion"
    with zipfile.ZipFile(a) as src, zipfile.ZipFile(damaged, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "manifest.json":
                doc = json.loads(data)
                doc["counts"]["recording_windows"] = "ten"
                data = json.dumps(doc).encode()
            dst.writestr(item, data)
    merge_map_files([damaged, b], tmp_path / "out.aion")
    assert "recording_windows" not in read_manifest(tmp_path / "out.aion")["counts"]


def test_a_merge_keeps_the_map_frame_its_inputs_share() -> None:
    from aion_cli.merge_frames import common_frame

    assert common_frame(["odom", "odom"]) == "odom"
    assert common_frame(["odom", "map"]) is None  # different frames: none recorded
    assert common_frame(["odom", None]) is None  # a map from before the record
    assert common_frame([]) is None


def test_maps_of_different_frames_merge_with_a_warning(tmp_path: Path) -> None:
    """Maps whose positions are in different frames ('right_laser' and 'rear_laser': two
    lasers of one robot, each built with its --map-frame) merged without a word into a map
    that records no frame; maps of one frame, or from before the record, stay quiet."""
    def frame_warnings(frames: tuple[str | None, str | None], name: str) -> list[str]:
        a, b = (
            fixed_sensor_map(tmp_path / f"{name}{k}.aion", (f"{name}{k}.mcap",),
                             T0 + k * DAY, seed=k, map_frame=f)
            for k, f in enumerate(frames)
        )
        report = merge_map_files([a, b], tmp_path / f"{name}.aion")
        return [w for w in report.warnings if "different frames" in w]

    warned = frame_warnings(("right_laser", "rear_laser"), "lasers")
    assert warned == [
        "the maps hold positions in different frames (lasers0.aion: 'right_laser', "
        "lasers1.aion: 'rear_laser'): they are merged as if both were one frame, and the "
        "merged map records none; merge maps of one frame (aion info MAP --format json: "
        "map_frame)"
    ]
    assert "map_frame" not in read_manifest(tmp_path / "lasers.aion")
    assert frame_warnings(("odom", "odom"), "same") == []
    assert read_manifest(tmp_path / "same.aion")["map_frame"] == "odom"
    assert frame_warnings(("odom", None), "older") == []


def test_three_frames_are_not_called_both() -> None:
    """Three maps of three frames were "merged as if both were one frame"."""
    from aion_cli.merge_frames import frame_warning

    two = frame_warning([("a.aion", "x"), ("b.aion", "y"), ("c.aion", "y")])
    assert two is not None
    assert "as if both were one frame" in two
    three = frame_warning([("a.aion", "x"), ("b.aion", "y"), ("c.aion", "z")])
    assert three is not None
    assert "as if all 3 were one frame" in three
