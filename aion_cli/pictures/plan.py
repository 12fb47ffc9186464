"""The plan picture: the temporal path and the distance-only path of ``aion plan`` over the
flow map at the departure time (the top-down picture of :mod:`.topdown` as background).

The distance-only path is drawn first, wide and dashed; the temporal path on top of it,
narrower and solid, so both stay visible where they share edges. Each legend entry gives the
path's length (m) and temporal cost, as ``aion plan`` prints them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.pictures.topdown import DPI, Color, Marker, PathLine, topdown_figure
from aion_cli.scene import Scene

F64 = npt.NDArray[np.float64]

TEMPORAL_GREEN: Color = (0.1, 0.7, 0.2)
DISTANCE_ORANGE: Color = (1.0, 0.6, 0.0)
START_COLOR: Color = (0.0, 0.0, 0.0)
GOAL_COLOR: Color = (0.85, 0.1, 0.6)


@dataclass(frozen=True)
class DrawnRoute:
    """One path of a plan to draw: its points f64[p,3], length (m) and temporal cost."""

    xyz: F64
    length_m: float
    cost: float


def plan_figure(
    scene: Scene,
    temporal: DrawnRoute,
    distance_only: DrawnRoute,
    *,
    start_label: str,
    goal_label: str,
    title: str,
    dpi: float = DPI,
    frame: str | None = None,
) -> Any:
    """The figure of a plan: ``scene`` at the departure with both paths, a start marker (a
    circle at the first point) and a goal marker (a star at the last point); the axes in
    ``frame`` (the map's, when known)."""
    lines = [
        PathLine(
            distance_only.xyz,
            f"distance only: {distance_only.length_m:.1f} m, cost {distance_only.cost:.1f}",
            DISTANCE_ORANGE,
            "--",
            4.5,
        ),
        PathLine(
            temporal.xyz,
            f"temporal: {temporal.length_m:.1f} m, cost {temporal.cost:.1f}",
            TEMPORAL_GREEN,
            "-",
            2.2,
        ),
    ]
    markers = end_markers(temporal.xyz, start_label, goal_label)
    return topdown_figure(
        [scene], [title], paths=[lines], markers=markers, dpi=dpi, frame=frame
    )


def end_markers(xyz: npt.ArrayLike, start_label: str, goal_label: str) -> list[Marker]:
    """The start (a circle at the first point of the path ``xyz`` f64[p,3]) and goal (a star
    at its last) markers of a path, labelled ``start <start_label>`` and ``goal
    <goal_label>``; none for an empty path."""
    ends = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if not len(ends):
        return []
    return [
        Marker(
            (float(ends[0, 0]), float(ends[0, 1])),
            f"start {start_label}",
            "o",
            START_COLOR,
            z=float(ends[0, 2]),
        ),
        Marker(
            (float(ends[-1, 0]), float(ends[-1, 1])),
            f"goal {goal_label}",
            "*",
            GOAL_COLOR,
            200.0,
            z=float(ends[-1, 2]),
        ),
    ]
