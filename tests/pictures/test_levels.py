"""A map of several levels (floors apart in height) is drawn one panel per level: the flows
of one floor are not drawn over another's."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.pictures.floors import levels
from aion_cli.pictures.plan import DrawnRoute, plan_figure
from aion_cli.pictures.topdown import topdown_figure
from aion_cli.scene import Scene
from tests.pictures.pixels import places_scene, synthetic_scene, the_legend


def _two_floors() -> Scene:
    """The same 3 x 3 places on the ground (z 0, walked +x) and 4 m above (walked -y), each
    floor's places joined along x; a room per floor."""
    xy = np.array([(x, y) for x in (0.0, 2.0, 4.0) for y in (0.0, 2.0, 4.0)])
    ground = np.column_stack([xy, np.zeros(9)])
    upper = np.column_stack([xy, np.full(9, 4.0)])
    xyz = np.concatenate([ground, upper])
    pairs = np.array([[k, k + 3] for k in range(6)] + [[k + 9, k + 12] for k in range(6)])
    return replace(
        synthetic_scene(),
        node_ids=np.arange(18, dtype=np.uint64),
        nodes_xyz=xyz,
        node_flow=np.ones(18),
        node_entropy=np.full(18, 0.1),
        node_angle=np.r_[np.zeros(9), np.full(9, -np.pi / 2)],
        node_concentration=np.full(18, 0.9),
        cells_xyz=np.zeros((0, 3)),
        cells_flow=np.zeros(0),
        cells_entropy=np.zeros(0),
        cells_angle=np.zeros(0),
        places_xyz=xyz,
        edges_xyz=xyz[pairs],
        room_ids=np.array([1, 2], dtype=np.uint64) | np.uint64(ord("R") << 56),
        room_labels=("lobby", "offices"),
        room_xyz=np.array([[2.0, 2.0, 0.0], [2.0, 2.0, 4.0]]),
        place_room=np.r_[np.zeros(9, np.int64), np.ones(9, np.int64)],
        mesh=None,
    )


def _panels(fig: Any) -> list[Any]:
    return [ax for ax in fig.axes if ax.get_title()]


def _quiver(ax: Any) -> Any:
    (q,) = [c for c in ax.collections if type(c).__name__ == "Quiver"]
    return q


def test_two_floors_are_two_panels_each_with_its_own_flows() -> None:
    """Before, both floors' arrows were drawn over each other in one panel, +x and -y at
    every place, with nothing saying the map had two floors."""
    scene = _two_floors()
    assert levels([scene]) == [(0.0, 0.0), (4.0, 4.0)]
    fig = topdown_figure([scene], ["Mon 08:00"], suptitle="two.aion")
    ground, upper = _panels(fig)
    assert ground.get_title() == "level z 0.0 m"
    assert upper.get_title() == "level z 4.0 m"
    assert fig.get_suptitle() == "two.aion\nMon 08:00"
    for ax, (u, v) in ((ground, (1.0, 0.0)), (upper, (0.0, -1.0))):
        q = _quiver(ax)
        assert q.N == 9
        np.testing.assert_allclose(np.sign(np.round(q.U, 9)), u)
        np.testing.assert_allclose(np.sign(np.round(q.V, 9)), v)
    labels = {t.get_text() for ax in (ground, upper) for t in ax.texts}
    assert [t.get_text() for t in ground.texts] == ["lobby"]
    assert labels == {"lobby", "offices"}


def test_a_series_of_a_two_floor_map_has_a_panel_per_time_and_floor() -> None:
    scene = _two_floors()
    titles = [ax.get_title() for ax in _panels(topdown_figure([scene, scene], ["a", "b"]))]
    assert titles == ["a\nlevel z 0.0 m", "a\nlevel z 4.0 m", "b\nlevel z 0.0 m",
                      "b\nlevel z 4.0 m"]


def test_a_path_up_the_stairs_is_drawn_on_each_floor_where_it_is() -> None:
    """The plan from the ground to the upper floor: the start on the ground's panel, the goal
    on the upper one's, each panel drawing the path's points on its floor; one legend."""
    xyz = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [4.0, 0.0, 4.0], [4.0, 4.0, 4.0]])
    route = DrawnRoute(xyz, 12.0, 20.0)
    fig = plan_figure(_two_floors(), route, route, start_label="p0", goal_label="p17",
                      title="plan")
    ground, upper = _panels(fig)
    for ax, kept in ((ground, [[0.0, 0.0], [4.0, 0.0]]), (upper, [[4.0, 0.0], [4.0, 4.0]])):
        (line,) = [ln for ln in ax.get_lines() if ln.get_label().startswith("temporal")]
        xy = line.get_xydata()
        np.testing.assert_allclose(xy[np.isfinite(xy).all(axis=1)], kept)
    marks = {ax: [c.get_label() for c in ax.collections if c.get_label().startswith(("start",
                                                                                     "goal"))]
             for ax in (ground, upper)}
    assert marks == {ground: ["start p0"], upper: ["goal p17"]}
    legend = the_legend(fig)
    assert {t.get_text() for t in legend.get_texts()} >= {"start p0", "goal p17"}


def test_one_floor_of_a_hydra_graph_is_one_level() -> None:
    """Places of one floor fill its free space at heights 0.1 to 3 m: one panel."""
    scene = synthetic_scene()
    z = np.linspace(0.1, 3.0, len(scene.places_xyz))
    one = replace(scene, places_xyz=np.column_stack([scene.places_xyz[:, :2], z]))
    assert len(levels([one])) == 1
    assert len(_panels(topdown_figure([one], ["t"]))) == 1


def test_a_row_of_panels_holds_whole_times() -> None:
    """Seven times of a two-floor map: each row holds both floors of its times."""
    scene = _two_floors()
    fig = topdown_figure([scene] * 7, [f"t{k}" for k in range(7)])
    rows: dict[float, list[str]] = {}
    for ax in _panels(fig):
        rows.setdefault(round(ax.get_position().y0, 3), []).append(ax.get_title())
    for titles in rows.values():
        assert len(titles) % 2 == 0
        assert [t.split("\n")[0] for t in titles[::2]] == [t.split("\n")[0] for t in titles[1::2]]


def test_a_series_of_too_many_times_on_levels_names_a_step_that_fits(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Thirteen hourly times of a two-floor map are 26 panels: the error said only "use a
    larger --step" after every scene was computed; it counts the levels and names a step
    that fits, before drawing anything."""
    from types import SimpleNamespace

    import aion_cli.scene
    from aion_cli.errors import InputError
    from aion_cli.pictures.render import export_png

    calls: list[int | None] = []

    def scene_at(loaded: object, t_ns: int | None) -> Scene:
        calls.append(t_ns)
        return _two_floors()

    monkeypatch.setattr(aion_cli.scene, "scene_at", scene_at)
    hour = 3600 * 10**9
    times = [1_767_600_000 * 10**9 + k * hour for k in range(13)]
    with pytest.raises(InputError) as err:
        export_png(SimpleNamespace(), "two.aion", tmp_path / "t.png", times, None)
    assert "26 panels (13 times on 2 levels)" in str(err.value)
    assert err.value.hint is not None
    assert "--step 2h draws this span in 14 panels" in err.value.hint
    assert len(calls) == 1
    assert not (tmp_path / "t.png").exists()


def _tower(floors: int) -> Scene:
    """One place per floor, 2 m apart in height: ``floors`` levels."""
    heights = 2.0 * np.arange(floors)
    return places_scene(np.column_stack([np.zeros(floors), np.zeros(floors), heights]))


def test_a_map_of_more_levels_than_panels_is_still_drawn() -> None:
    """A map of 30 levels (heights 2 m apart: a tower, or detections at many heights) could
    not be drawn at all: one time asked for 30 panels, more than 24, and was refused with a
    hint to use a larger --step, which no step satisfies; ``aion report`` of such a map
    failed for its map picture. Its levels are drawn over each other in one panel a time,
    as before levels were drawn apart; a map of 24 levels still gets a panel each."""
    from aion_cli.pictures.topdown import MAX_PANELS

    fig = topdown_figure([_tower(30)], ["Mon 08:00"], suptitle="tower.aion")
    (panel,) = _panels(fig)
    assert panel.get_title() == "Mon 08:00"
    assert len(_panels(topdown_figure([_tower(MAX_PANELS)], ["Mon 08:00"]))) == MAX_PANELS


def test_export_png_of_a_map_of_more_levels_than_panels(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``export --format png`` refused the one time of such a map before drawing it."""
    import aion_cli.pictures.render as render

    monkeypatch.setattr("aion_cli.scene.scene_at", lambda loaded, t_ns: _tower(30))
    monkeypatch.setattr(render, "_mark_unobserved", lambda loaded, times, titles: titles)
    out = render.export_png(None, "tower.aion", tmp_path / "t.png", [None], None)
    assert out.is_file()


@pytest.mark.parametrize(("size", "top"), [(0.5, "0.5"), (0.25, "0.25")])
def test_a_level_of_hash_cells_is_titled_by_the_heights_its_cells_cover(
    size: float, top: str
) -> None:
    """People detected on floors at z 0 and 4 m fill the hash cells 0 to 0.5 m and 4 to
    4.5 m (centres 0.25 and 4.25); the panels were titled "level z 0.2 m" and "level z
    4.2 m" (the centres to one decimal), heights no floor of the data has. They give the
    cells' bottom and top, the floor's height first."""
    from aion_cli.engine.spatial_hash import cell_centres, keys_for_points

    seen = np.array([[x, 1.0, z] for z in (0.0, 4.0) for x in (0.0, 1.0, 2.0, 3.0)])
    centres = cell_centres(np.unique(keys_for_points(seen, size)), size)
    n = len(centres)
    scene = replace(
        _two_floors(), cell_size=size, cells_xyz=centres, cells_flow=np.ones(n),
        cells_entropy=np.full(n, 0.1), cells_angle=np.zeros(n),
        node_ids=np.zeros(0, np.uint64), nodes_xyz=np.zeros((0, 3)), node_flow=np.zeros(0),
        node_entropy=np.zeros(0), node_angle=np.zeros(0), node_concentration=np.zeros(0),
        places_xyz=np.zeros((0, 3)), edges_xyz=np.zeros((0, 2, 3)),
        place_room=np.zeros(0, np.int64),
    )
    titles = [ax.get_title() for ax in _panels(topdown_figure([scene], [""]))]
    assert titles == [f"level z 0.0 to {top} m", f"level z 4.0 to 4{top[1:]} m"]
