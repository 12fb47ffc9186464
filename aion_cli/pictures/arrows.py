"""The arrows of a top-down picture: one per node and unbound hash cell with flow, or, where
the picture cannot resolve that many, one per block of a coarser grid.

A map of 10^5 hash cells over 160 m drawn eight inches wide gives each cell a twentieth of a
pixel: one arrow per cell is a solid carpet. When the picture's arrow spacing
(:data:`ARROWS_PER_INCH` arrows per inch of panel width) is more than :data:`MERGE_FROM` times
the map's cell size, the arrows of each square block of that spacing (a grid anchored at the
origin, so every panel of a series has the same blocks) become one:

- at the flow-weighted centroid of the block's entries,
- as long as their flows summed (the picture's arrow scale, :class:`ArrowScale`, is then
  that of the blocks),
- along the direction most of that flow takes: the entries' dominant directions binned in
  eight bins (as the map bins headings by default), weighted by flow, and the flow-weighted
  mean direction of the largest bin (as an entry's dominant direction is its largest bin's;
  a flow-weighted mean of all of them would point across a corridor walked both ways),
- coloured by the flow-weighted mean of their direction entropies.

The cells' squares and the graph are drawn as always, the squares fainter; the nodes' dots,
which overlap where arrows merge, are left out (a carpet of the arrows' colours hid them), but
for those of nodes with flow and no direction (teal: people standing), whose flow no arrow
carries.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.descriptors import bin_of
from aion_cli.formats.scene_colours import (
    busy_fraction,
    colour_key,
    display_flow_scale,
    has_no_flow,
    has_no_heading,
)
from aion_cli.pictures.backdrop import Extent, median_nearest, squares_of
from aion_cli.scene import Scene

F64 = npt.NDArray[np.float64]

ARROWS_PER_INCH = 7.0
"""The densest arrows a picture draws, per inch of panel width (about 17 pixels apart at the
pictures' 120 dpi)."""
MERGE_FROM = 3.0
"""Arrows merge into blocks when the block would be more than this many cells wide (one arrow
per cell would then be under six pixels from the next; a 45 m corridor of 0.5 m cells, 1.7
cells per block, keeps one per cell)."""
ARROW_CELLS = 4.0
"""The arrow of the busiest flow is this many hash cells long (one arrow per entry)."""
BLOCK_ARROW = 0.9
"""A merged arrow at full length spans this share of its block (when that is longer)."""
REACH = 2.0
"""An arrow of one entry at full flow is at most this many times the arrows' spacing long
(:func:`arrow_spacing`; never under :data:`MIN_ARROW_CELLS` cells): at :data:`ARROW_CELLS`
cells, 2 m, over cells and Hydra places 0.3-0.5 m apart (the Lincoln corridor, a Matterport
house), the busiest arrows crossed three or four of their neighbours, a red tangle over the
junction."""
MIN_ARROW_CELLS = 2.0
"""The shortest an arrow at full flow is drawn, in cells, however close the arrows: at one
cell (0.5 m) over a house's places 0.3 m apart, the busiest arrows were heads without shafts
and the rest dots."""

HEAD_LENGTH = 4.0
"""An arrow's head is this many shaft widths long (3.5 wide) where the arrows are long..."""
HEAD_SHARE = 1.0 / 3.0
"""...but at most this share of the arrow. The busiest arrows of a picture drawn under
``HEAD_LENGTH / HEAD_SHARE`` shaft widths long get a head a third of them (at least
:data:`LEAST_HEAD` widths long, :data:`LEAST_HEAD_WIDTH` wide), and an arrow shorter than
three heads is drawn as a smaller copy of one that long (head, shaft and width scaled alike,
matplotlib's ``minshaft``). At matplotlib's one head length of four widths, a merged map's
arrows (a block of about 15 pixels, the shafts 3 pixels wide) were all head, a field of
triangles that did not read as flow."""
LEAST_HEAD = 1.5
LEAST_HEAD_WIDTH = 2.5


def head_style(full_widths: float) -> dict[str, float]:
    """The quiver's head parameters (shaft widths) for a picture whose arrows at full flow are
    ``full_widths`` shaft widths long (:data:`HEAD_LENGTH`, :data:`HEAD_SHARE`), for
    ``Axes.quiver``."""
    head = float(np.clip(HEAD_SHARE * full_widths, LEAST_HEAD, HEAD_LENGTH))
    return {
        "headwidth": max(0.875 * head, LEAST_HEAD_WIDTH),
        "headlength": head,
        "headaxislength": 0.875 * head,
        "minshaft": 1.0 / HEAD_SHARE,
    }


NO_ARROWS = "no arrows: no place or cell has flow with a direction here"
"""The legend of a picture in which nothing flows (in any panel of a series)."""


@dataclass(frozen=True)
class ArrowScale:
    """The flow drawn at full arrow length (``flow``), the largest flow (``largest``), and
    the legend that says how lengths read."""

    flow: float
    largest: float

    def legend(self, window_s: float) -> str:
        """How lengths read, the flows to three significant digits (no exponent: a square's
        busiest crowd read "1.57e+03 detections")."""
        from aion_cli.number_text import significant

        flow = significant(self.flow)
        # one flow, one detection: "up to 1 detections" read wrong
        per = f"detection{'' if flow == '1' else 's'} per {window_s:g}-s window"
        if self.flow >= self.largest:
            return (
                f"arrows: dominant direction, length proportional to flow (the longest: "
                f"{flow} {per})"
            )
        return (
            f"arrows: dominant direction, length proportional to flow up to "
            f"{flow} {per} (busier entries drawn that long; the largest "
            f"{significant(self.largest)})"
        )


def arrow_scale(scenes: Sequence[Scene]) -> ArrowScale:
    """The arrow scale of one picture (every panel shares it): the flows of every node and
    cell of ``scenes`` with a direction (those without draw no arrow: people standing in a
    queue shrank every arrow to a dot) through :func:`formats.scene_colours.display_flow_scale`
    (linear up to the busiest flow, or up to a high quantile when the busiest dwarfs the rest)."""
    flows = np.concatenate(
        [
            np.r_[s.node_flow, s.cells_flow] * np.isfinite(np.r_[s.node_angle, s.cells_angle])
            for s in scenes
        ]
    )
    return ArrowScale(*display_flow_scale(flows))


@dataclass(frozen=True)
class ArrowField:
    """The arrows to draw: tails ``xy`` f64[n,2], ``flow`` (detections per window), dominant
    ``angle`` (rad from +x), direction ``entropy`` (0..1), and ``block``, the edge of the
    blocks they were merged over (m; None: one arrow per entry)."""

    xy: F64
    flow: F64
    angle: F64
    entropy: F64
    block: float | None
    spacing: float | None = None
    """The arrows' typical spacing (m, :func:`arrow_spacing`), which caps their length;
    None: not capped."""

    def full_length(self, cell_size: float) -> float:
        """The length of an arrow at full flow (m): :data:`ARROW_CELLS` cells, at most
        :data:`REACH` times the arrows' spacing (but :data:`MIN_ARROW_CELLS` cells); a merged
        arrow's, as long as :data:`BLOCK_ARROW` of its block when that is longer."""
        if self.block is None:
            return min(ARROW_CELLS * cell_size, _reach(self.spacing, cell_size))
        return max(ARROW_CELLS * cell_size, BLOCK_ARROW * self.block)

    def lengths(self, flow_scale: float, cell_size: float) -> F64:
        """Each arrow's drawn length (m) at ``flow_scale`` (the flow drawn at full length):
        :meth:`full_length` times ``formats.scene_colours.busy_fraction`` (0: not drawn)."""
        busy: F64 = busy_fraction(self.flow, flow_scale)
        return self.full_length(cell_size) * busy

    def length_note(self, cell_size: float) -> str:
        """The legend's line on the arrows' length when their spacing shortened them ("" when
        it did not): how long the longest is drawn, and why."""
        full = self.full_length(cell_size)
        if self.block is not None or self.spacing is None or full >= ARROW_CELLS * cell_size:
            return ""
        if REACH * self.spacing >= MIN_ARROW_CELLS * cell_size:
            return (
                f"the longest arrow drawn {full:.2g} m long, {REACH:g} times the arrows' "
                f"typical spacing ({self.spacing:.2g} m), so that it does not run over its "
                "neighbours"
            )
        return (
            f"the longest arrow drawn {full:.2g} m long ({MIN_ARROW_CELLS:g} cells; the "
            f"arrows are typically {self.spacing:.2g} m apart)"
        )

    def legend(self) -> str:
        """How the arrows were merged, for the picture's legend ("" when they were not)."""
        if self.block is None:
            return ""
        return (
            # the edge as it is, a whole number of cells (two digits said "10" of 10.5 m)
            f"one arrow per {self.block:.4g} m block (the flow of its places and cells summed, "
            "along the direction most of it takes)"
        )


def _reach(spacing: float | None, cell_size: float) -> float:
    """The longest an arrow may be at ``spacing`` (:data:`REACH` times it, at least
    :data:`MIN_ARROW_CELLS` cells; unbounded without a spacing)."""
    if spacing is None or not spacing > 0:
        return float("inf")
    return max(REACH * spacing, MIN_ARROW_CELLS * cell_size)


def arrow_spacing(fields: Sequence[ArrowField]) -> float | None:
    """The typical spacing of the arrows of ``fields`` (the panels of one picture, which
    share it): the median distance from each distinct tail to its nearest neighbour; None
    for fewer than two tails or merged arrows (their blocks space them)."""
    if any(f.block is not None for f in fields):
        return None
    xy = np.concatenate([f.xy for f in fields] + [np.zeros((0, 2))])
    tails = np.unique(xy[:, 0] + 1j * xy[:, 1])
    if tails.size < 2:
        return None
    return median_nearest(np.column_stack([tails.real, tails.imag]))


def spaced(fields: Sequence[ArrowField]) -> list[ArrowField]:
    """``fields`` carrying their shared :func:`arrow_spacing` (which caps the arrows'
    length, :meth:`ArrowField.full_length`)."""
    from dataclasses import replace

    spacing = arrow_spacing(fields)
    return [replace(f, spacing=spacing) for f in fields]


def arrow_block(
    extent: Extent,
    panel_width_in: float,
    cell_size: float,
    panel_height_in: float | None = None,
) -> float | None:
    """The edge of the blocks the arrows of a panel ``panel_width_in`` by ``panel_height_in``
    inches (None: as high as the map needs) showing ``extent`` merge over, or None where one
    arrow per entry can be seen. The panel draws x and y on one scale, the metres per inch
    of the direction that fills it: a map along y (a corridor 200 m long and 2 m wide, drawn
    nine inches high) was judged by its width alone, so its 400 arrows of 2 m were drawn on
    a line 23 m an inch long, one over the next, a dotted stripe without a visible arrow.

    The edge is a whole number of cells (the spacing rounded up), so that every block of the
    cell lattice, anchored at the origin as the blocks are, holds as many cells as the next: a
    block of 6.2 cells held six rows of cells or seven, and a map walked evenly was drawn in
    stripes of arrows a third longer every sixth block."""
    per_inch = (extent.x1 - extent.x0) / panel_width_in
    if panel_height_in is not None:
        per_inch = max(per_inch, (extent.y1 - extent.y0) / panel_height_in)
    spacing = per_inch / ARROWS_PER_INCH
    if not spacing > MERGE_FROM * cell_size:
        return None
    return float(np.ceil(spacing / cell_size - 1e-9) * cell_size)


def arrow_field(scene: Scene, block: float | None = None, bins: int = 8) -> ArrowField:
    """The arrows of ``scene``: every node and unbound cell with flow and a direction, merged
    over blocks of ``block`` metres when given (the module docstring)."""
    xy = np.concatenate([scene.nodes_xyz[:, :2], scene.cells_xyz[:, :2]])
    flow = np.nan_to_num(
        np.concatenate([scene.node_flow, scene.cells_flow]), nan=0.0, posinf=0.0, neginf=0.0
    )
    angle = np.concatenate([scene.node_angle, scene.cells_angle])
    entropy = np.concatenate([scene.node_entropy, scene.cells_entropy])
    has = (flow > 0) & np.isfinite(angle) & np.isfinite(xy).all(axis=1)
    xy, flow, angle, entropy = xy[has], flow[has], angle[has], entropy[has]
    if block is None or len(flow) == 0:
        return ArrowField(xy, flow, angle, entropy, None)
    squares, of = squares_of(xy, block)
    n = len(squares)
    total: F64 = np.bincount(of, flow, minlength=n).astype(np.float64)
    centroid = np.column_stack(
        [np.bincount(of, flow * xy[:, k], minlength=n) / total for k in range(2)]
    )
    heading_bin = bin_of(angle, bins)
    per_bin = np.bincount(of * bins + heading_bin, flow, minlength=n * bins).reshape(n, bins)
    top = np.argmax(per_bin, axis=1)
    major = heading_bin == top[of]
    c = np.bincount(of[major], flow[major] * np.cos(angle[major]), minlength=n)
    s = np.bincount(of[major], flow[major] * np.sin(angle[major]), minlength=n)
    mean_entropy = np.bincount(of, flow * np.nan_to_num(entropy, nan=1.0), minlength=n) / total
    return ArrowField(centroid, total, np.arctan2(s, c), mean_entropy, float(block))


def legend_lines(scale: str, fields: Sequence[ArrowField], scenes: Sequence[Scene]) -> list[str]:
    """The legend of a picture, a line each: how the arrows read (``scale``, the arrow scale's
    legend; :data:`NO_ARROWS` when no panel has one: the scale of no flow read "the longest: 1
    detections"), the colours off the entropy scale (grey, and teal where some entry has flow
    without a heading), and how the arrows were merged ("" when they were not)."""
    teal = any(
        has_no_heading(np.r_[s.node_flow, s.cells_flow], np.r_[s.node_entropy, s.cells_entropy])
        for s in scenes
    )
    grey = any(has_no_flow(np.r_[s.node_flow, s.cells_flow]) for s in scenes)
    arrows = scale if any(len(f.flow) for f in fields) else NO_ARROWS
    if not len(fields):
        return [arrows, colour_key(teal, grey), ""]
    length = fields[0].length_note(scenes[0].cell_size) if any(len(f.flow) for f in fields) else ""
    return [arrows, length, colour_key(teal, grey), fields[0].legend()]
