"""The key of a top-down picture's arrows: one reference arrow of a stated flow
("= 4.5 detections per 600-s window"), drawn by matplotlib's ``quiverkey`` from the panel's own
quiver, so that it is exactly as long as an arrow of that flow in the panel (the caption alone
gave the scale in words). One key per figure, in the corner of the last panel that covers the
fewest drawn points (none, where the map leaves a corner empty; where it leaves none, on a
white ground)."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.pictures.backdrop import LABEL_GREY

F64 = npt.NDArray[np.float64]

KEY_POINTS = 7.0
"""The key's text size (points)."""
KEY_INSET = 0.02
"""The key's distance from the panel's frame (a share of the panel)."""
LABEL_SEP_IN = 0.08
"""The gap between the key's arrow and its text (inches)."""


def key_flow(flow_scale: float) -> float:
    """The flow the key's arrow stands for: ``flow_scale`` (the flow drawn at full length)
    rounded down to two significant digits (4.55 -> 4.5), so the key is about as long as the
    longest arrow (a round 1, 2 or 5 drew the key of a series' panels, arrows of a few pixels,
    as a head without a shaft) and reads as a short number."""
    if not flow_scale > 0 or not np.isfinite(flow_scale):
        return 0.0
    power = 10.0 ** (np.floor(np.log10(flow_scale)) - 1.0)
    return float(np.floor(flow_scale / power + 1e-9) * power)


def key_label(flow: float, window_s: float) -> str:
    """The key's text: the flow its arrow stands for, per window."""
    from aion_cli.number_text import significant

    noun = "detection" if flow == 1.0 else "detections"
    return f"= {significant(flow)} {noun}\nper {window_s:g}-s window"


def key_corner(
    points: F64, limits: tuple[float, float, float, float], box: tuple[float, float]
) -> tuple[float, float, int]:
    """The lower left of the key (axes fraction) in the corner of the window ``limits``
    (x0, x1, y0, y1) whose box of ``box`` (width, height; axes fraction) holds the fewest of
    ``points`` f64[n,2] (data), and how many it holds; ties: lower right, upper right, lower
    left, upper left."""
    x0, x1, y0, y1 = limits
    w, h = box
    fx = (points[:, 0] - x0) / (x1 - x0)
    fy = (points[:, 1] - y0) / (y1 - y0)
    right, top = 1.0 - KEY_INSET - w, 1.0 - KEY_INSET - h
    corners = [(right, KEY_INSET), (right, top), (KEY_INSET, KEY_INSET), (KEY_INSET, top)]
    pad = KEY_INSET
    counts = [
        int(np.count_nonzero((fx >= cx - pad) & (fx <= cx + w + pad)
                             & (fy >= cy - pad) & (fy <= cy + h + pad)))
        for cx, cy in corners
    ]
    best = int(np.argmin(counts))
    return corners[best][0], corners[best][1], counts[best]


def draw_arrow_key(
    ax: Any,
    flow_scale: float,
    full_length: float,
    window_s: float,
    points: F64,
    panel_in: tuple[float, float],
) -> Any:
    """Draw the key of the arrows of panel ``ax`` (the quiver it holds; None is returned when
    it holds none): an arrow of :func:`key_flow` (``full_length`` metres at ``flow_scale``,
    proportionally shorter below it) and its :func:`key_label`, in the emptiest corner
    (:func:`key_corner`) of the drawn ``points`` f64[n,2]; ``panel_in``: the panel's width
    and height (inches), which size the key's box. Returns the ``QuiverKey``."""
    quivers = [c for c in ax.collections if type(c).__name__ == "Quiver"]
    flow = key_flow(flow_scale)
    if not quivers or not flow > 0:
        return None
    length = full_length * min(flow / flow_scale, 1.0)
    label = key_label(flow, window_s)
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    # the panel draws x and y on one scale: the metres per inch of the direction that fills it
    per_inch = max((x1 - x0) / panel_in[0], (y1 - y0) / panel_in[1])
    arrow_in = length / per_inch
    # the text's width estimated generously: constrained layout draws a panel smaller than
    # ``panel_in`` (its tick labels), so the text covers more metres than the estimate says
    text_in = max(len(line) for line in label.splitlines()) * 0.8 * KEY_POINTS / 72.0
    high_in = 3.0 * KEY_POINTS / 72.0
    drawn_w = (x1 - x0) / per_inch  # the panel's drawn size (inches)
    drawn_h = (y1 - y0) / per_inch
    box = ((arrow_in + LABEL_SEP_IN + text_in) / drawn_w, high_in / drawn_h)
    cx, cy, covered = key_corner(points, (x0, x1, y0, y1), box)
    if covered:  # no corner is empty (a map filling its window): the key on a white ground
        from matplotlib.patches import Rectangle

        ax.add_patch(Rectangle(
            (cx - KEY_INSET / 2, cy - KEY_INSET / 2), box[0] + KEY_INSET, box[1] + KEY_INSET,
            transform=ax.transAxes, facecolor="white", alpha=0.85, edgecolor="none", zorder=29,
        ))
    # the arrow on the frame's side, its text towards the panel's middle: text estimated a
    # little short does not run out of the panel
    right = cx + box[0] / 2.0 > 0.5
    return ax.quiverkey(
        quivers[0],
        cx + box[0] - arrow_in / drawn_w if right else cx,
        cy + box[1] / 2.0,
        length,
        label,
        coordinates="axes",
        labelpos="W" if right else "E",
        labelsep=LABEL_SEP_IN,
        color=LABEL_GREY,
        labelcolor=LABEL_GREY,
        fontproperties={"size": KEY_POINTS},
        zorder=30,
    )


def drawn_points(scene: Any, tails: F64, heads: F64, paths: Any = ()) -> F64:
    """The points a panel draws (f64[n,2]): the arrows' tails and heads, the places, nodes,
    cells, mesh vertices and paths of ``scene`` (a :class:`~aion_cli.scene.Scene`)."""
    parts = [tails, heads, scene.places_xyz[:, :2], scene.nodes_xyz[:, :2],
             scene.cells_xyz[:, :2]]
    if scene.mesh is not None:
        parts.append(np.asarray(scene.mesh.vertices, np.float64).reshape(-1, 3)[:, :2])
    parts += [np.asarray(p.xyz, np.float64).reshape(-1, 3)[:, :2] for p in paths]
    xy = np.concatenate([np.asarray(p, np.float64).reshape(-1, 2) for p in parts])
    out: F64 = xy[np.isfinite(xy).all(axis=1)]
    return out
