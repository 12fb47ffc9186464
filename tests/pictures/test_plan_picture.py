"""The plan picture: both routes in their own colours over the flow map, start and goal
markers, and each route's length and cost in the legend (checked on the PNG's pixels)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.pictures.plan import (
    DISTANCE_ORANGE,
    GOAL_COLOR,
    TEMPORAL_GREEN,
    DrawnRoute,
    plan_figure,
)
from aion_cli.pictures.render import save_png
from aion_cli.pictures.topdown import Color
from tests.pictures.pixels import (
    F64,
    count_near,
    pixel_of,
    places_scene,
    read_png,
    synthetic_scene,
    the_legend,
    window,
)

Point = tuple[float, ...]
A, B, C = (0.0, 0.0, 0.0), (8.0, 0.0, 0.0), (0.0, 8.0, 0.0)


def _share(image: F64, ax: Any, p: Point, q: Point, color: Color) -> float:
    """The fraction of points along the segment p-q (its middle 60 %) with a pixel of
    ``color`` next to them."""
    hits = []
    for f in np.linspace(0.2, 0.8, 25):
        x, y = p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1])
        patch = window(image, *pixel_of(ax, image, x, y), half=2)
        hits.append(bool((np.abs(patch - np.asarray(color)).max(axis=1) < 0.1).any()))
    return float(np.mean(hits))


def test_both_routes_start_goal_and_legend(tmp_path: Path) -> None:
    """Temporal A -> C -> B (around), distance only A -> B (straight)."""
    temporal = DrawnRoute(np.array([A, C, B]), 19.3, 4.5)
    shortest = DrawnRoute(np.array([A, B]), 8.0, 9.25)
    fig = plan_figure(
        synthetic_scene(),
        temporal,
        shortest,
        start_label="p1",
        goal_label="p2",
        title="p1 to p2",
        dpi=100,
    )
    image = read_png(save_png(fig, tmp_path / "plan.png", "--png"))
    (ax,) = [a for a in fig.axes if a.get_title() == "p1 to p2"]
    assert _share(image, ax, C, B, TEMPORAL_GREEN) > 0.9  # solid, only the temporal route
    assert _share(image, ax, C, B, DISTANCE_ORANGE) == 0.0
    assert _share(image, ax, (3.0, 0.0), B, DISTANCE_ORANGE) > 0.5  # dashed
    assert _share(image, ax, (3.0, 0.0), B, TEMPORAL_GREEN) == 0.0
    assert count_near(image, GOAL_COLOR) > 20
    goal = window(image, *pixel_of(ax, image, *B[:2]), half=3)
    assert (np.abs(goal - np.asarray(GOAL_COLOR)).max(axis=1) < 0.1).any()
    legend = [t.get_text() for t in the_legend(fig).get_texts()]
    assert legend == [
        "distance only: 8.0 m, cost 9.2",
        "temporal: 19.3 m, cost 4.5",
        "start p1",
        "goal p2",
    ]


def test_the_same_route_twice_shows_both_colours(tmp_path: Path) -> None:
    """When both routes are the same path, the temporal one (narrow, on top) leaves the wide
    distance-only line visible on both sides."""
    route = DrawnRoute(np.array([A, C]), 8.0, 3.0)
    fig = plan_figure(
        synthetic_scene(), route, route, start_label="p1", goal_label="p3", title="t", dpi=100
    )
    image = read_png(save_png(fig, tmp_path / "plan.png"))
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    assert _share(image, ax, A, C, TEMPORAL_GREEN) > 0.9
    assert _share(image, ax, A, C, DISTANCE_ORANGE) > 0.5


def test_the_legend_covers_no_map() -> None:
    """A plan along a 100 m corridor 2 m wide: the legend, in the panel's upper right corner,
    covered the goal and half of both paths. It has a row of its own over the panels, clear
    of the title and the caption too."""
    xy = np.array([(x, y) for x in np.arange(0.5, 100.0, 1.0) for y in (0.5, 1.5)])
    scene = places_scene(np.column_stack([xy, np.zeros(len(xy))]))
    route = DrawnRoute(np.array([[0.5, 0.5, 0.0], [99.5, 0.5, 0.0]]), 99.0, 120.0)
    fig = plan_figure(scene, route, route, start_label="p0", goal_label="p198", title="plan")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = the_legend(fig).get_window_extent(renderer)
    (ax,) = [a for a in fig.axes if a.get_title() == "plan"]
    assert not box.overlaps(ax.get_window_extent(renderer))
    assert not box.overlaps(ax.title.get_window_extent(renderer))
    assert not box.overlaps(fig._supxlabel.get_window_extent(renderer))
    assert fig.bbox.contains(box.x0, box.y0)
    assert fig.bbox.contains(box.x1, box.y1)
