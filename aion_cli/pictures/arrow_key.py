"""The key of a top-down picture's arrows: one reference arrow of a stated flow
("= 4.55 detections per 600-s window"), drawn by matplotlib's ``quiverkey`` from the panel's own
quiver, so that it is exactly as long as an arrow of that flow in the panel (the caption alone
gave the scale in words). One key per figure, in the corner of the last panel with arrows where
that panel draws nothing; where the map leaves no corner empty, over the panels, in a row of
its own (a white ground under it in a corner covered the data)."""

from __future__ import annotations

from dataclasses import dataclass
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
    """The flow the key's arrow stands for: ``flow_scale`` (the flow drawn at full length) to
    the three significant digits the caption states it in (:class:`.arrows.ArrowScale`'s
    legend, ``number_text.significant``: 4.55, 150 for 149.7), so that the key and the
    caption name one number (rounded down to two digits, the key said "= 140 detections"
    under a caption of "up to 150"); as long as the longest arrow (a round 1, 2 or 5 drew the
    key of a series' panels, arrows of a few pixels, as a head without a shaft). Rounded up,
    it is drawn at full length, as a busier entry is."""
    if not flow_scale > 0 or not np.isfinite(flow_scale):
        return 0.0
    from aion_cli.number_text import significant

    return float(significant(flow_scale).replace(",", ""))


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


@dataclass(frozen=True)
class KeyPlan:
    """Where and what the key is, known before the figure is made: the ``panel`` (index)
    whose quiver it is drawn from, its arrow's ``length`` (m) and ``label``, the lower left
    (``corner``, axes fraction) and size (``box``) of its place in that panel's emptiest
    corner, how long the arrow is drawn there (``arrow_share`` of the panel's width), and
    ``in_margin``: no corner is empty (a map filling its window), so it goes over the panels,
    in a row of its own (:func:`draw_arrow_key`), not over data."""

    panel: int
    length: float
    label: str
    corner: tuple[float, float]
    box: tuple[float, float]
    arrow_share: float
    in_margin: bool


def plan_key(
    panel: int,
    flow_scale: float,
    full_length: float,
    window_s: float,
    points: F64,
    limits: tuple[float, float, float, float],
    panel_in: tuple[float, float],
) -> KeyPlan | None:
    """The key of the arrows of panel ``panel`` (None without a flow to show): an arrow of
    :func:`key_flow` (``full_length`` metres at ``flow_scale``, proportionally shorter below
    it) and its :func:`key_label`, in the corner (:func:`key_corner`) of the window
    ``limits`` (x0, x1, y0, y1) that holds the fewest of the drawn ``points`` f64[n,2], or
    in the margin when each holds some; ``panel_in``: the panel's width and height
    (inches), which size the key's box."""
    flow = key_flow(flow_scale)
    if not flow > 0 or not full_length > 0:
        return None
    length = full_length * min(flow / flow_scale, 1.0)
    label = key_label(flow, window_s)
    x0, x1, y0, y1 = limits
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
    cx, cy, covered = key_corner(points, limits, box)
    return KeyPlan(panel, length, label, (cx, cy), box, arrow_in / drawn_w, covered > 0)


def draw_arrow_key(ax: Any, plan: KeyPlan, margin: Any = None) -> Any:
    """Draw the key ``plan`` of the arrows of panel ``ax`` (the quiver it holds; None is
    returned when it holds none) in its corner, or, for a key ``in_margin``, in the axes
    ``margin`` (a row over the panels, its axis off) over the panel's left edge, on one
    line. Returns the ``QuiverKey``."""
    quivers = [c for c in ax.collections if type(c).__name__ == "Quiver"]
    if not quivers:
        return None
    style: dict[str, Any] = {
        "color": LABEL_GREY, "labelcolor": LABEL_GREY, "labelsep": LABEL_SEP_IN,
        "fontproperties": {"size": KEY_POINTS}, "zorder": 30,
    }
    if plan.in_margin and margin is not None:
        key = _margin_key(margin, quivers[0], plan.length, plan.label.replace("\n", " "), style)
        margin.add_artist(key)
        key.set_clip_on(False)  # drawn past its row's axes, which the layout makes room for
        return key
    cx, cy = plan.corner
    w, h = plan.box
    # the arrow on the frame's side, its text towards the panel's middle: text estimated a
    # little short does not run out of the panel; the arrow within the box (labelled east,
    # quiverkey puts the arrow's tip at X)
    right = cx + w / 2.0 > 0.5
    return ax.quiverkey(
        quivers[0],
        cx + w - plan.arrow_share if right else cx + plan.arrow_share,
        cy + h / 2.0,
        plan.length,
        plan.label,
        coordinates="axes",
        labelpos="W" if right else "E",
        **style,
    )


def _margin_key(host: Any, quiver: Any, length: float, label: str, style: dict[str, Any]) -> Any:
    """A ``QuiverKey`` of ``quiver`` placed in the axes ``host`` (matplotlib places a key in
    its quiver's own axes): mid-height in the host, the arrow's tail over the left edge of
    the quiver's panel, its text to the right; its extent (text and arrow) is what the
    layout makes room for."""
    from matplotlib.quiver import QuiverKey
    from matplotlib.transforms import Affine2D, Bbox, blended_transform_factory

    class MarginKey(QuiverKey):
        def _set_transform(self) -> None:
            # quiverkey's eastward label puts the arrow's tip at X: shifted by the arrow's
            # drawn length (pixels, from the panel's scale after layout), its tail is at 0
            panel: Any = self.Q.axes
            x0, x1 = panel.get_xlim()
            shift = length * panel.bbox.width / (x1 - x0)
            at = blended_transform_factory(panel.transAxes, host.transAxes)
            self.set_transform(at + Affine2D().translate(shift, 0.0))

        def get_window_extent(self, renderer: Any = None) -> Any:
            key: Any = self  # quiverkey's own parts, untyped in matplotlib's stubs
            key._init()
            at = self.get_transform().transform((self.X, self.Y))
            key.text.set_position(at + key._text_shift())
            # the arrow's polygon in pixels (a collection placed in other than data
            # coordinates reports no extent of its own)
            vector = key.vector
            offset = vector.get_offset_transform().transform(vector.get_offsets())[0]
            xy = vector.get_transform().transform(vector.get_paths()[0].vertices) + offset
            return Bbox.union([key.text.get_window_extent(renderer),
                               Bbox([xy.min(axis=0), xy.max(axis=0)])])

    return MarginKey(quiver, 0.0, 0.5, length, label, labelpos="E", coordinates="axes",
                     **style)


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


def key_of(
    scenes: Any,
    fields: Any,
    drawn: Any,
    paths: Any,
    flow_scale: float,
    extent: Any,
    panel_in: tuple[float, float],
) -> KeyPlan | None:
    """The :class:`KeyPlan` of a figure whose panels show ``scenes`` (their
    :class:`~aion_cli.scene.Scene`) with the arrows ``fields`` (:class:`.arrows.ArrowField`)
    drawn ``drawn`` long (m), and ``paths``, in the window ``extent`` (an
    :class:`.backdrop.Extent`), panels ``panel_in`` inches: the key of the last panel with
    arrows (None without any)."""
    with_arrows = [i for i in range(len(scenes)) if (drawn[i] > 0).any()]
    if not with_arrows:
        return None
    last = with_arrows[-1]
    field, scene = fields[last], scenes[last]
    tails = field.xy
    ends = tails + drawn[last][:, None] * np.column_stack([np.cos(field.angle),
                                                           np.sin(field.angle)])
    return plan_key(
        last, flow_scale, field.full_length(scene.cell_size), scene.window_s,
        drawn_points(scene, tails, ends, paths[last]),
        (extent.x0, extent.x1, extent.y0, extent.y1), panel_in,
    )
