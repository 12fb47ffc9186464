"""The window a top-down picture shows: every place, node and path, and the hash cells but a
few outlying ones (stray detections far from where people walk), which the picture counts and
names in its legend. Checked on scenes whose geometry says by hand what must be left out."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.pictures.backdrop import OUTLIER_SHARE, OUTLIER_TOTAL, outlying_cells
from aion_cli.pictures.topdown import PathLine, scene_extent, topdown_figure
from tests.pictures.pixels import cells_only_scene

CELL = 0.5


def _corridor(length_m: float = 20.0, width_m: float = 2.0) -> np.ndarray:
    """Cell centres filling a corridor along +x from the origin."""
    xs = np.arange(CELL / 2, length_m, CELL)
    ys = np.arange(CELL / 2, width_m, CELL)
    return np.array([(x, y) for x in xs for y in ys])


def test_a_stray_cell_far_away_is_left_out_and_named() -> None:
    corridor = _corridor()
    xy = np.vstack([corridor, [[150.0, -30.0]]])
    flow = np.r_[np.full(len(corridor), 5.0), 0.01]
    scene = cells_only_scene(xy, flow)
    box = scene_extent([scene])
    assert box.x1 < 30.0  # the corridor fills the view
    assert box.y0 > -5.0
    assert box.x0 <= 0.0  # all of it
    assert box.x1 >= 20.0
    assert box.y1 >= 2.0
    assert box.left_out == 1
    assert box.left_out_share == 0.01 / flow.sum()
    assert box.caption().startswith("1 outlying hash cell (")
    fig = topdown_figure([scene], ["t"])
    assert "1 outlying hash cell" in fig._supxlabel.get_text()


def test_a_thin_arm_that_touches_the_corridor_stays() -> None:
    """A side corridor walked by few (far below the outliers' share) is part of the place:
    its cells touch the main corridor's, so the view keeps it."""
    corridor = _corridor()
    arm = np.array([(10.25, y) for y in np.arange(2.25, 15.0, CELL)])
    xy = np.vstack([corridor, arm])
    flow = np.r_[np.full(len(corridor), 50.0), np.full(len(arm), 0.001)]
    assert not outlying_cells(xy, flow, CELL).any()
    box = scene_extent([cells_only_scene(xy, flow)])
    assert box.y1 >= 15.0
    assert box.left_out == 0
    assert box.caption() == ""


def test_two_busy_sites_far_apart_are_both_shown() -> None:
    a = _corridor()
    xy = np.vstack([a, a + np.array([200.0, 0.0])])
    flow = np.ones(len(xy))
    assert not outlying_cells(xy, flow, CELL).any()
    box = scene_extent([cells_only_scene(xy, flow)])
    assert box.x0 <= 0.0
    assert box.x1 >= 220.0


def test_a_busy_cell_far_away_is_shown() -> None:
    """Far but holding a share of the flow above the outliers' share: not an outlier."""
    corridor = _corridor()
    xy = np.vstack([corridor, [[150.0, 0.0]]])
    flow = np.r_[np.ones(len(corridor)), 3 * OUTLIER_SHARE * len(corridor)]
    assert not outlying_cells(xy, flow, CELL).any()
    assert scene_extent([cells_only_scene(xy, flow)]).x1 >= 150.0


def test_a_near_stray_is_not_worth_leaving_out() -> None:
    """Apart from the corridor but within its span's reach: showing it costs little."""
    corridor = _corridor()
    xy = np.vstack([corridor, [[25.0, 1.0]]])  # 5 m beyond a 20 m corridor
    flow = np.r_[np.ones(len(corridor)), 1e-6]
    assert not outlying_cells(xy, flow, CELL).any()


def test_places_nodes_and_paths_are_always_in_view() -> None:
    """Only hash cells are ever left out: the graph and a planned path stay whole."""
    corridor = _corridor()
    xy = np.vstack([corridor, [[150.0, -30.0]]])
    flow = np.r_[np.ones(len(corridor)), 1e-6]
    far_place = np.array([[0.0, 80.0, 0.0]])
    scene = replace(cells_only_scene(xy, flow), places_xyz=far_place)
    path = PathLine(np.array([[0.0, 0.0, 0.0], [-60.0, 0.0, 0.0]]), "path", (0.0, 0.0, 0.0))
    box = scene_extent([scene], [path])
    assert box.y1 >= 80.0
    assert box.x0 <= -60.0
    assert box.left_out == 1  # the stray cell is still left out


def test_stray_cells_beside_a_graph_are_left_out_by_all_the_flow() -> None:
    """A map whose places hold nearly all the flow and a few unbound cells: the cells far
    from every place are outliers by their share of all the flow (although they are most of
    the unbound cells' own), a cell beside a place is not, and every place stays."""
    places = np.array([[x, y, 0.0] for x in range(0, 21, 2) for y in (0.0, 2.0)])
    n = len(places)
    cells = np.array([[150.0, -30.0], [-80.0, 10.0], [4.3, 0.2]])
    scene = replace(
        cells_only_scene(cells, np.array([0.1, 0.1, 0.1])),
        places_xyz=places,
        nodes_xyz=places.copy(),
        node_ids=np.arange(1, n + 1, dtype=np.uint64),
        node_flow=np.full(n, 50.0),
        node_entropy=np.full(n, 0.5),
        node_angle=np.zeros(n),
        node_concentration=np.full(n, 0.5),
    )
    out = outlying_cells(cells, scene.cells_flow, CELL, places[:, :2], scene.node_flow)
    assert out.tolist() == [True, True, False]
    box = scene_extent([scene])
    assert box.left_out == 2
    assert box.left_out_share == 0.2 / (0.3 + 50.0 * n)
    assert box.x0 > -10.0
    assert box.x1 < 30.0
    assert box.x1 >= 20.0  # every place


def test_a_series_counts_each_cell_once() -> None:
    corridor = _corridor()
    xy = np.vstack([corridor, [[150.0, -30.0], [-120.0, 40.0]]])
    flow = np.r_[np.ones(len(corridor)), 1e-4, 1e-4]
    scene = cells_only_scene(xy, flow)
    box = scene_extent([scene, scene, scene])
    assert box.left_out == 2
    assert box.caption().startswith("2 outlying hash cells (")


def test_no_flow_anywhere_weighs_every_cell_alike() -> None:
    """Then a group's share is its share of the cells: one of 801 is an outlier, one of 161
    is not."""
    for length, stray in ((100.0, True), (20.0, False)):
        corridor = _corridor(length)
        xy = np.vstack([corridor, [[400.0, -30.0]]])
        out = outlying_cells(xy, np.zeros(len(xy)), CELL)
        assert out.tolist() == [False] * len(corridor) + [stray]


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(-500, 500, allow_nan=False),
            st.floats(-500, 500, allow_nan=False),
            st.floats(0, 100, allow_nan=False),
        ),
        min_size=0,
        max_size=60,
    ),
    st.floats(0.1, 2.0),
)
def test_what_is_left_out_is_little_and_apart(cells: list[tuple[float, float, float]],
                                              cell: float) -> None:
    """Whatever the cells: the flow left out is at most the documented total, and every kept
    cell lies inside the picture's window."""
    xy = np.array([(x, y) for x, y, _ in cells]).reshape(-1, 2)
    flow = np.array([f for _, _, f in cells])
    out = outlying_cells(xy, flow, cell)
    assert out.shape == (len(xy),)
    weights = flow if flow.sum() > 0 else np.ones(len(flow))
    if len(xy):
        assert weights[out].sum() <= OUTLIER_TOTAL * weights.sum() + 1e-9
        assert not out.all()
    scene = replace(cells_only_scene(xy, flow), cell_size=cell)
    box = scene_extent([scene])
    kept = xy[~out]
    assert (kept[:, 0] >= box.x0).all()
    assert (kept[:, 0] <= box.x1).all()
    assert (kept[:, 1] >= box.y0).all()
    assert (kept[:, 1] <= box.y1).all()
    assert box.left_out <= len(np.unique(xy[out], axis=0))  # those drawn are not left out


def test_the_ticks_give_the_map_s_own_coordinates() -> None:
    """A corridor 200 km east and 300 km north of the map's origin: matplotlib's offset
    notation labelled its x ticks 0 ... 30 with "+2e5" in a corner (and y likewise), so the
    picture read as a corridor at the origin. Every tick's label is its coordinate in the
    map, and there is no offset text."""
    along = np.arange(0.25, 30.0, 0.5)
    xy = np.array([(200_000.0 + x, 300_000.0 + y) for x in along for y in (0.25, 0.75)])
    n = len(xy)
    fig = topdown_figure([cells_only_scene(xy, np.ones(n), np.zeros(n), np.full(n, 0.2))], ["t"])
    fig.canvas.draw()
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        assert axis.get_offset_text().get_text() == ""
        ticks = [
            (float(loc), float(label.get_text().replace("\u2212", "-")))
            for loc, label in zip(axis.get_majorticklocs(), axis.get_ticklabels(), strict=True)
            if lo <= loc <= hi
        ]
        assert ticks, "no tick in the window"
        for loc, label in ticks:
            assert label == pytest.approx(loc), ticks
