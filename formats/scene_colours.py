"""The drawing rules every picture and scene format shares: colours and sizes from flow and
entropy (DESIGN.md §7; the PLY / PCD export's docstring, :mod:`formats.export`, says what is
drawn with them).

* entropy ``H`` (0..1) is the colour ``(H, 0, 1 − H)``: blue for one direction, red for every
  direction (:func:`entropy_colors`); an entry without flow is grey, one with flow but no
  heading (people standing still, or detections no track gave a heading) teal, a colour off
  the blue-to-red scale (:func:`flow_colors`, the one decision every format draws; the
  pictures' legends say it with :func:`colour_key`);
* flow is drawn linearly up to ``flow_scale`` (:func:`busy_fraction`), the busiest flow or,
  where it dwarfs the rest, a high quantile (:func:`display_flow_scale`); a node's sphere
  grows from ``0.2·δ`` to ``δ`` with it (:func:`sphere_radii`);
* edges are grey, a planned path green.

Why a module of its own: the scene styles (:mod:`formats.scene_style`), the MCAP markers and
the top-down pictures (``aion_cli.pictures``) draw by the same rules, and none of them needs
the open3d writers of :mod:`formats.export`.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]

NO_FLOW_GREY = (0.5, 0.5, 0.5)
NO_HEADING_TEAL = (0.0, 0.6, 0.6)
"""Flow without a heading: the entry has detections but none with a direction, so its
entropy is undefined (NaN); drawn grey it read as "no flow" where people stood."""
NO_FLOW_KEY = "grey: no flow"
NO_HEADING_KEY = "teal: flow without a heading (people standing still or untracked)"
EDGE_GREY = (0.6, 0.6, 0.6)
PATH_GREEN = (0.1, 0.8, 0.2)
RADIUS_MIN_FACTOR = 0.2
RADIUS_MAX_FACTOR = 1.0


def entropy_colors(entropy: npt.ArrayLike) -> F64:
    """``(H, 0, 1 − H)`` per row (H clipped to 0..1); grey for NaN (no flow)."""
    h = np.asarray(entropy, dtype=np.float64).reshape(-1)
    out = np.empty((len(h), 3))
    known = np.isfinite(h)
    hc = np.clip(h[known], 0.0, 1.0)
    out[known] = np.stack([hc, np.zeros_like(hc), 1.0 - hc], axis=1)
    out[~known] = NO_FLOW_GREY
    return out


def _flowing(flow: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Per entry, whether it has flow (> 0; NaN and +inf read as none): what is coloured by
    entropy or teal, the rest grey."""
    f = np.nan_to_num(np.asarray(flow, dtype=np.float64).reshape(-1), nan=0.0, posinf=0.0)
    return f > 0


def flow_colors(flow: npt.ArrayLike, entropy: npt.ArrayLike) -> F64:
    """The colour of each entry: its entropy colour (:func:`entropy_colors`) where it has
    flow and a direction, :data:`NO_HEADING_TEAL` where it has flow (> 0) but no direction
    (entropy NaN), :data:`NO_FLOW_GREY` without flow (0, NaN or negative)."""
    h = np.asarray(entropy, dtype=np.float64).reshape(-1)
    flowing = _flowing(flow)
    out = entropy_colors(np.where(flowing, h, np.nan))
    out[flowing & ~np.isfinite(h)] = NO_HEADING_TEAL
    return out


def has_no_heading(flow: npt.ArrayLike, entropy: npt.ArrayLike) -> bool:
    """Whether any entry has flow but no direction (drawn :data:`NO_HEADING_TEAL`)."""
    h = np.asarray(entropy, dtype=np.float64).reshape(-1)
    return bool(np.any(_flowing(flow) & ~np.isfinite(h)))


def has_no_flow(flow: npt.ArrayLike) -> bool:
    """Whether any entry has no flow (0, NaN or negative: drawn :data:`NO_FLOW_GREY`)."""
    return not bool(_flowing(flow).all())


def colour_key(no_heading: bool, no_flow: bool = True) -> str:
    """The legend of the colours off the entropy scale that are drawn: grey (``no_flow``) and
    teal (``no_heading``); "" when neither is (a legend names no colour the picture lacks)."""
    return "; ".join(k for k, drawn in ((NO_FLOW_KEY, no_flow), (NO_HEADING_KEY, no_heading))
                     if drawn)


DISPLAY_QUANTILE = 0.95
"""Flows at or above this quantile get full size when the busiest flow dwarfs them
(:func:`display_flow_scale`)."""
DISPLAY_QUANTILE_FROM = 20
"""The quantile rule applies from this many entries with flow (fewer: the busiest is full
size)."""


def display_flow_scale(flow: npt.ArrayLike) -> tuple[float, float]:
    """The flow drawn at full size (arrow length, sphere radius) and the largest flow, for
    ``flow`` (every entry drawn, over every step of a series). Sizes are linear in flow up to
    the busiest flow; but real maps' flows are heavy-tailed (a mall entrance with 60
    detections a window, most places under 1), and then every other entry would be a dot: when
    :data:`DISPLAY_QUANTILE_FROM` or more entries have flow and the busiest is more than twice
    their :data:`DISPLAY_QUANTILE` quantile, that quantile is drawn at full size instead.
    ``(1, 1)`` without flow."""
    f = np.asarray(flow, dtype=np.float64).reshape(-1)
    f = f[np.isfinite(f) & (f > 0)]
    if f.size == 0:
        return 1.0, 1.0
    largest = float(f.max())
    if f.size >= DISPLAY_QUANTILE_FROM:
        high = float(np.quantile(f, DISPLAY_QUANTILE))
        if high > 0 and 2.0 * high < largest:
            return high, largest
    return largest, largest


def busy_fraction(flow: npt.ArrayLike, flow_scale: float) -> F64:
    """``min(flow / flow_scale, 1)``, NaN and negative flow count as 0."""
    f = np.nan_to_num(np.asarray(flow, dtype=np.float64).reshape(-1), nan=0.0, posinf=0.0)
    return np.clip(f / flow_scale, 0.0, 1.0)


def sphere_radii(flow: npt.ArrayLike, flow_scale: float, cell_size: float) -> F64:
    """Radius per node: ``δ·(0.2 + 0.8·busy)``."""
    busy = busy_fraction(flow, flow_scale)
    lo, hi = RADIUS_MIN_FACTOR * cell_size, RADIUS_MAX_FACTOR * cell_size
    return lo + (hi - lo) * busy
