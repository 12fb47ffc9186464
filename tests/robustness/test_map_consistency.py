"""Maps whose checksums are valid but whose arrays contradict each other are refused when
loaded (``MapCorruptError``: one ``error:`` line naming the member, exit 2), for ``predict``
and for ``build --map``. Each used to load: some then gave negative or NaN flows with exit 0,
others an internal error (exit 1) in a later query.

Maps are crafted from a real one (a 28-hour log: closed days, a pending day, redirects, a
graph): arrays read with ``read_map``, edited, and written back with ``write_map``, so every
member's sha256 matches and only the load-time checks stand between the edit and a query.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.formats.mapfile import read_map, write_map
from tests.robustness.conftest import (
    T0,
    S,
    assert_one_error,
    build_json,
    graph_payload,
    person,
    robot_tf,
    run,
    scene_graph,
    walk,
    write_log,
)

RESERVED = ("format", "version", "creator", "created", "members")
Arrays = dict[str, np.ndarray]


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A map of 28 hours of people around a robot with a scene graph: one day closed, the
    next pending, cells bound to places (redirects), unbound cells."""
    folder = tmp_path_factory.mktemp("consistency")
    msgs = sorted(
        [
            *[person(T0 + k * 60 * S, (2.1 + k % 5, 0.1 * (k % 7), 0.0), track=k % 4)
              for k in range(1700)],
            *[robot_tf(T0 + 30 * k * S) for k in range(3400)],
            scene_graph(T0 + 1, graph_payload()),
        ],
        key=lambda m: m[3],
    )
    log = write_log(folder / "day.mcap", msgs)
    build_json(log, "-o", folder / "day.aion")
    return folder / "day.aion"


def crafted(source: Path, out: Path, edit: Callable[[Arrays, dict[str, Any]], None]) -> Path:
    """``source`` with ``edit(arrays, state_meta)`` applied, rewritten with valid checksums."""
    arrays, manifest = read_map(source)
    arrays = {k: np.array(v) for k, v in arrays.items()}
    manifest = {k: v for k, v in manifest.items() if k not in RESERVED}
    edit(arrays, manifest["state"])
    write_map(out, arrays, manifest)
    return out


def _set(name: str, index: Any, value: Any, dtype: Any = None) -> Callable[[Arrays, Any], None]:
    def edit(a: Arrays, meta: Any) -> None:
        if dtype is not None:
            a[name] = a[name].astype(dtype)
        a[name][index] = value

    return edit


def _cut(name: str) -> Callable[[Arrays, Any], None]:
    def edit(a: Arrays, meta: Any) -> None:
        a[name] = a[name][:-1]

    return edit


def _meta(key: str, value: Any) -> Callable[[Arrays, Any], None]:
    def edit(a: Arrays, meta: Any) -> None:
        meta[key] = value

    return edit


def _reverse(name: str) -> Callable[[Arrays, Any], None]:
    def edit(a: Arrays, meta: Any) -> None:
        a[name] = a[name][::-1].copy()

    return edit


def _first_after_last(a: Arrays, meta: Any) -> None:
    a["temporal_obs_first"][0] = a["temporal_obs_last"][0] + 1e6


def _one_more_detection(a: Arrays, meta: Any) -> None:
    a["entry_counts"][0, 0] += 1.0


def _recorded_share(value: float) -> Callable[[Arrays, Any], None]:
    """A pending day's recorded share of ``value`` for every window (a robot's windows: none
    was a fixed sensor's, so only 1 would be consistent)."""

    def edit(a: Arrays, meta: Any) -> None:
        a["pending_fixed_share"] = np.full(a["pending_windows"].size, value)

    return edit


def _backwards_interval(a: Arrays, meta: Any) -> None:
    a["obs_fixed_start"] = np.array([10], np.int64)
    a["obs_fixed_end"] = np.array([5], np.int64)


# (edit, fragment of the error line). "today:" what the unchecked load did.
CASES: dict[str, tuple[Callable[[Arrays, Any], None], str]] = {
    # today: exit 0, the negative count in the histograms / flows
    "negative count": (_set("entry_counts", (2, 0), -50.0), "entry_counts holds -50.0"),
    "NaN count": (_set("entry_counts", (2, 0), np.nan), "entry_counts holds nan"),
    "infinite speed sum": (_set("entry_speed_sum", (1, 4), np.inf), "entry_speed_sum holds inf"),
    "negative undirected count": (_set("entry_nodir", 2, -7.0), "entry_nodir holds -7.0"),
    "open-window count above the total": (
        _set("entry_window_counts", (0, 4), 1e6), "entry_window_counts exceeds entry_counts"),
    "counts that do not add up to the accepted detections": (
        _one_more_detection, "the entries hold 1701 detections but the map accepted 1700"),
    # today: exit 1, "internal error: ValueError: 'x' must be finite"
    "NaN entry position": (_set("entry_xyz", (2, 0), np.nan), "entry_xyz holds nan"),
    "negative cell key": (_set("entry_key", 0, -5), "negative spatial-hash key"),
    # before stop 70: finite, so loaded, and grouped by an int64 cast of -1e300
    "entry far beyond the spatial hash": (
        _set("entry_xyz", (2, 0), -1e300),
        "entry_xyz holds -1e+300 (row 2), beyond the spatial hash's range (±524288 m"),
    # today: exit 0, predicted flows from NaN observation counts / a negative profile
    "NaN observed windows": (_set("temporal_obs_n", 0, np.nan), "temporal_obs_n holds nan"),
    "negative observed windows per profile bin": (
        _set("temporal_obs_profile", (0, 0), -3.0, np.float64),
        "temporal_obs_profile holds -3.0"),
    "observation that ends before it starts": (_first_after_last, "temporal_obs_first / _last"),
    # today: exit 0, historical flow -4.5 detections per window
    "negative pending count": (_set("pending_cnt_values", (0, 4), -99.0, np.float64),
                               "pending_cnt_values holds -99.0"),
    "pending window of another day": (_set("pending_windows", 0, 5), "not windows of the pending"),
    "two nodes with one id": (_set("node_ids", 1, 0), "node_ids are not sorted and unique"),
    "node table of different lengths": (_cut("node_xyz"), "members of different lengths"),
    "NaN node position": (_set("node_xyz", (0, 1), np.nan), "node_xyz holds nan"),
    # today: exit 1, "internal error: IndexError"
    "redirects of different lengths": (_cut("redirect_nodes"), "redirect_keys 8, redirect_nodes 7"),
    "graph parents of different lengths": (_cut("graph_places_parent"),
                                           "members of different lengths"),
    # today: exit 0 (an edge to nowhere was dropped or wrapped around)
    "edge to a place that does not exist": (_set("graph_edges", (0, 1), 999),
                                            "graph_edges refer to places outside 0..6"),
    "NaN place": (_set("graph_places_xyz", (3, 2), np.nan), "graph_places_xyz holds nan"),
    "robot poses out of time order": (_reverse("obs_pose_t"), "obs_pose_t is not sorted"),
    "poses of different lengths": (_cut("obs_pose_xy"), "obs_pose_t 20, obs_pose_xy 19"),
    # before stop 70: a distance from it overflowed to inf (engine.sensor_reach)
    "robot pose far beyond the spatial hash": (
        _set("obs_pose_xy", (3, 1), 1e300), "obs_pose_xy holds 1e+300 (row 3), beyond"),
    # before stop 71: loaded (a build refuses such a place: ownership.check_graph)
    "place far beyond the spatial hash": (
        _set("graph_places_xyz", (3, 1), 6e5), "graph_places_xyz holds 600000 (row 3), beyond"),
    "node far beyond the spatial hash": (
        _set("node_xyz", (1, 0), -1e300), "node_xyz holds -1e+300 (row 1), beyond"),
    "node reference far beyond the spatial hash": (
        _set("node_ref_xyz", (2, 2), 1e9), "node_ref_xyz holds 1e+09 (row 2), beyond"),
    "fixed-sensor interval backwards": (_backwards_interval, "ends before it starts"),
    "negative drop count": (_meta("dropped", {"nan": -3}), "negative drop counts"),
    "open window in the year 2e10": (_meta("open_window", 10**18), "the open window"),
    "negative log time": (_meta("log_time_ns", -1), "the log time -1 ns"),
}


@pytest.mark.parametrize("value", [0.5, 1.5, 0.0, np.nan])
def test_a_recorded_share_that_cannot_be_is_one_error_line(
    source: Path, tmp_path: Path, value: float
) -> None:
    """A fixed sensor's recorded share on a robot's window (only 1 is consistent there), or
    outside (0, 1]: the member is named, exit 2."""
    bad = crafted(source, tmp_path / "bad.aion", _recorded_share(value))
    result = run("predict", bad, "--historical", "--format", "json")
    assert result.exit_code == 2, (result.exit_code, result.stderr)
    assert_one_error(result.stderr, "pending_fixed_share is not one share in (0, 1]")
    assert result.stdout == ""


@pytest.mark.parametrize("case", sorted(CASES))
def test_an_inconsistent_map_is_one_error_line(source: Path, tmp_path: Path, case: str) -> None:
    edit, fragment = CASES[case]
    bad = crafted(source, tmp_path / "bad.aion", edit)
    result = run("predict", bad, "--historical", "--format", "json")
    assert result.exit_code == 2, (result.exit_code, result.stderr)
    assert_one_error(result.stderr, "map state is inconsistent", fragment)
    assert result.stdout == ""


def test_the_unedited_rewrite_loads_and_predicts(source: Path, tmp_path: Path) -> None:
    """The control: rewriting the arrays unchanged gives a map that loads and whose flows are
    finite and non-negative (so the refusals above are the edits, not the rewrite)."""
    same = crafted(source, tmp_path / "same.aion", lambda a, m: None)
    for args in (("--historical",), ("--time", "2026-11-23 08:30", "--tz", "UTC")):
        result = run("predict", same, *args, "--format", "json")
        assert result.exit_code == 0, result.stderr
    import json

    flows = [e["flow"] for e in json.loads(result.stdout)["entries"]]
    assert flows
    assert all(f is not None and f >= 0 for f in flows)


@pytest.mark.parametrize("case", ["negative pending count", "redirects of different lengths"])
def test_build_map_refuses_an_inconsistent_map_and_leaves_it(
    source: Path, tmp_path: Path, case: str
) -> None:
    bad = crafted(source, tmp_path / "bad.aion", CASES[case][0])
    before = bad.read_bytes()
    log = write_log(tmp_path / "more.mcap", walk(20, start_s=200_000))
    result = run("build", "--map", bad, log)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, CASES[case][1])
    assert bad.read_bytes() == before
