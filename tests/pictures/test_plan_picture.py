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
from tests.pictures.pixels import F64, count_near, pixel_of, read_png, synthetic_scene, window

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
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
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
