"""``aion merge`` of maps whose detections lie apart: a map of another place, or of one place
recorded in another frame (a shifted or turned copy of a log), is warned of as ``aion build
LOG --map OLD`` warns of logs of another place (``build_plausibility.merge_ground_warning``,
the same bar ``NEW_GROUND_SHARE``), naming the map(s) away from the others; two days of one
place are not. The warning comes from the API's ``aion.merge`` too."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.build_options import BuildOptions
from aion_cli.build_plausibility import NEW_GROUND_SHARE, Ground, away_by_map
from aion_cli.errors import AionWarning
from aion_cli.merging import merge_map_files
from aion_cli.pipeline import build_map
from tests.robustness.conftest import T0, Message, S, person, write_log

DAY_S = 86_400


def _corridor(seed: int, n: int = 120) -> np.ndarray:
    """``n`` positions in a corridor 12 m long (x 0-12) and 2 m wide (y 0-2)."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0, 12, n), rng.uniform(0, 2, n)])


def _log(path: Path, xy: np.ndarray, day: int) -> Path:
    """A person at each of ``xy``, one every 10 s from 09:00 of day ``day`` after T0."""
    start = day * DAY_S + 9 * 3600
    msgs: list[Message] = [
        person(T0 + (start + 10 * k) * S, (float(x), float(y), 0.0), track=k % 4 + 1)
        for k, (x, y) in enumerate(xy)
    ]
    return write_log(path, msgs)


def _map(folder: Path, name: str, xy: np.ndarray, day: int) -> Path:
    out = folder / f"{name}.aion"
    build_map(BuildOptions(logs=(_log(folder / f"{name}.mcap", xy, day),), output=out))
    return out


def _turned(xy: np.ndarray, degrees: float, shift: tuple[float, float]) -> np.ndarray:
    """``xy`` in another frame: turned by ``degrees`` about the origin, then shifted."""
    a = math.radians(degrees)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return xy @ rot.T + np.asarray(shift)


def _away(report_warnings: list[str]) -> list[str]:
    return [w for w in report_warnings if "from every entry of" in w]


def test_a_map_in_another_frame_is_named(tmp_path: Path) -> None:
    """Days 0 and 1 of the corridor, and day 2 recorded in a frame turned by 90 degrees
    (the corridor then runs along y, from x 0 to -2): the turned map is named, alone."""
    day0 = _map(tmp_path, "day0", _corridor(1), 0)
    day1 = _map(tmp_path, "day1", _corridor(2), 1)
    turned_xy = _turned(_corridor(3), 90.0, (0.0, 0.0))
    turned = _map(tmp_path, "turned", turned_xy, 2)
    # what the warning must say, counted here from the positions: the turned day's detections
    # farther than 1 m (bind_radius) from every cell centre (0.5 m cells) the two days hold
    held = np.vstack([_corridor(1), _corridor(2)])
    centres = np.unique((np.floor(held / 0.5) + 0.5) * 0.5, axis=0)
    cells = np.unique(np.floor(turned_xy / 0.5), axis=0)
    per_cell = np.array([np.sum(np.all(np.floor(turned_xy / 0.5) == c, axis=1)) for c in cells])
    cell_xy = (cells + 0.5) * 0.5
    near = np.array([np.min(np.hypot(*(centres - p).T)) <= 1.0 for p in cell_xy])
    share = per_cell[~near].sum() / len(turned_xy)
    assert share > NEW_GROUND_SHARE  # the case is one the rule is for

    report = merge_map_files([day0, day1, turned], tmp_path / "all.aion")
    warned = _away(report.warnings)
    assert len(warned) == 1, report.warnings
    assert f"{share:.0%} of the 120 of turned.aion" in warned[0], warned[0]
    assert "day0.aion" not in warned[0]
    assert "day1.aion" not in warned[0]
    assert "another frame?" in warned[0]
    # two days of one place: nothing to warn of
    assert _away(merge_map_files([day0, day1], tmp_path / "days.aion").warnings) == []


def test_a_shifted_copy_is_warned_of_by_the_api_too(tmp_path: Path) -> None:
    """Two maps 500 m apart (another building, or a frame shifted so far): each lies wholly
    away from the other, and both are named, by ``aion merge`` and by ``aion.merge``."""
    here = _map(tmp_path, "here", _corridor(1), 0)
    far = _map(tmp_path, "far", _corridor(2) + 500.0, 1)
    with pytest.warns(AionWarning) as caught:
        aion.merge([here, far], tmp_path / "both.aion")
    warned = _away([str(w.message) for w in caught])
    assert len(warned) == 1, [str(w.message) for w in caught]
    assert "100% of the 120 of here.aion; 100% of the 120 of far.aion" in warned[0]
    assert "from every entry of the other map" in warned[0]


def test_away_by_map_is_the_distance_rule_entry_by_entry() -> None:
    """``away_by_map`` (one tree of every entry, the positions two maps share looked up once)
    against the rule written out for each entry and every entry of the other maps: cells
    within 1 m, places within 2 m (strictly) or of an id another map has a place of."""
    rng = np.random.default_rng(5)
    for trial in range(4):
        grounds = []
        for k in range(3):
            m = 300
            xy = (np.floor(rng.uniform(0, 12, (m, 2)) / 0.5) + 0.5) * 0.5
            xy += (k == 2) * (2.0 + trial)  # the third map shifted, more each trial
            node = rng.uniform(size=m) < 0.3
            ids = np.where(node, rng.integers(1, 60, m), 0).astype(np.uint64)
            grounds.append(Ground(np.column_stack([xy, np.zeros(m)]), ids, node,
                                  rng.uniform(0, 5, m)))
        for by_id in (True, False):
            got = away_by_map(grounds, 1.0, by_id=by_id)
            for k, g in enumerate(grounds):
                others = [o for j, o in enumerate(grounds) if j != k]
                oxy = np.vstack([o.xyz[:, :2] for o in others])
                d = np.hypot(*(g.xyz[:, None, :2] - oxy[None]).transpose(2, 0, 1)).min(axis=1)
                near = np.where(g.is_node, d < 2.0, d <= 1.0)
                if by_id:
                    places = np.concatenate([o.node_id[o.is_node] for o in others])
                    near |= g.is_node & np.isin(g.node_id, places)
                assert got[k] == pytest.approx(g.detections[~near].sum(), abs=1e-9)
