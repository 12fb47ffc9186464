"""``aion merge`` reads each map's state only when its turn comes: it plans from the maps'
heads (manifest, graph, config: :func:`aion_cli.mapquery.load_map_head`) and holds the merged
map and the map being added, not every input at once (a fleet's maps need not fit in memory
together). The merged maps themselves are checked in ``tests/test_merging.py``."""

from __future__ import annotations

import gc
import weakref
from pathlib import Path

import numpy as np
import pytest

from aion_cli import merging
from aion_cli.engine.state import MapState
from aion_cli.errors import InputError, MapCorruptError, MapFileError
from aion_cli.mapquery import load_map, load_map_head
from aion_cli.merging import merge_map_files
from tests.engine.engine_builders import T0
from tests.engine.state_logs import DAY, run_steps
from tests.formats.map_damage import flip_member_byte
from tests.merging_logs import log_span, random_log, save_map

NODES = np.array([[0, 0, 0], [3, 0, 0], [0, 3, 0], [3, 3, 0], [6, 6, 0.0]])


def _maps(folder: Path, count: int) -> list[Path]:
    """``count`` maps of one scene-graph session, two days apart."""
    return [
        save_map(
            run_steps(random_log(T0 + 2 * k * DAY, 10 + k, 4, NODES)).state,
            folder / f"m{k}.aion",
            (f"log{k}",),
            log_span(T0 + 2 * k * DAY, 4),
        )
        for k in range(count)
    ]


def test_a_merge_holds_the_merged_map_and_the_map_being_added_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    paths = _maps(tmp_path, 5)
    states: list[weakref.ref[MapState]] = []
    alive_when_reading: list[int] = []
    read = merging._Input.load

    def counting(self: merging._Input) -> MapState:
        gc.collect()
        alive_when_reading.append(sum(ref() is not None for ref in states))
        state = read(self)
        states.append(weakref.ref(state))
        return state

    monkeypatch.setattr(merging._Input, "load", counting)
    report = merge_map_files(paths, tmp_path / "out.aion")
    assert alive_when_reading == [0, 1, 1, 1, 1]  # before: every map was read first (0..4)
    merged = load_map(tmp_path / "out.aion", writable=True).state
    assert merged.accepted == report.detections == sum(
        load_map(p).state.accepted for p in paths
    )


def test_the_head_of_a_map_is_its_manifest_graph_and_config(tmp_path: Path) -> None:
    (path,) = _maps(tmp_path, 1)
    head, loaded = load_map_head(path), load_map(path)
    assert head.manifest == loaded.manifest
    assert head.config == loaded.state.config
    assert head.open_window == loaded.state.open_window
    assert head.accepted == loaded.state.accepted
    assert not head.part
    assert loaded.graph is not None
    assert head.graph is not None
    np.testing.assert_array_equal(head.graph.places.ids, loaded.graph.places.ids)
    np.testing.assert_array_equal(head.graph.places.xyz, loaded.graph.places.xyz)


def test_a_damaged_state_member_is_found_when_the_fold_reads_it(tmp_path: Path) -> None:
    """The head does not read the accumulators; the merge still refuses the damaged map
    (when it reads that map's state) and writes nothing."""
    first, second = _maps(tmp_path, 2)
    bad = flip_member_byte(second, "temporal_cnt_profile", tmp_path / "bad.aion")
    assert load_map_head(bad).accepted == load_map(second).state.accepted  # head reads fine
    with pytest.raises(MapCorruptError, match="temporal_cnt_profile"):
        merge_map_files([first, bad], tmp_path / "out.aion")
    assert not (tmp_path / "out.aion").exists()


def test_a_map_that_changes_during_the_merge_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The merge records each map's sha256 from its first read: a map replaced before its
    state is read would be merged under the wrong provenance."""
    first, second = _maps(tmp_path, 2)
    (tmp_path / "other").mkdir()
    other = _maps(tmp_path / "other", 3)
    read = merging._Input.load

    def replaced(self: merging._Input) -> MapState:
        if self.path == second:
            second.write_bytes(other[2].read_bytes())
        return read(self)

    monkeypatch.setattr(merging._Input, "load", replaced)
    with pytest.raises(InputError, match="changed while it was being merged"):
        merge_map_files([first, second], tmp_path / "out.aion")
    assert not (tmp_path / "out.aion").exists()


def test_a_missing_map_is_refused_by_the_head_reader(tmp_path: Path) -> None:
    with pytest.raises(MapFileError, match="not found"):
        load_map_head(tmp_path / "none.aion")


def test_first_robot_windows_for_the_notes_equal_the_query_views() -> None:
    """The merge notes read each entry's first robot-observed window without preparing a
    query's copy of the state: the same values as the query view (pending day and open
    window absorbed), on a robot's map whose last day is pending and window open."""
    import numpy as np

    from aion_cli.merge_notes import _first_observed
    from tests.engine.state_logs import MORNING, robot_log

    state = run_steps(robot_log(MORNING, 31, days=2)).state
    assert state.pending
    assert state.open_window is not None
    first = _first_observed(state)
    view = state.query_temporal().obs.first
    rows = state.entries.live_rows()
    assert np.isfinite(view[rows]).sum() > 5  # robot-observed entries are there
    stored = state.temporal.obs.first[rows]
    assert not np.array_equal(stored, view[rows], equal_nan=True)  # the pending day matters
    np.testing.assert_array_equal(first[rows], view[rows])
