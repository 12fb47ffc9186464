"""The page of a top-down picture: how many rows and columns of panels, and how large
(inches), for the map's shape; a thin map (a corridor) gets no rows of white around it."""

from __future__ import annotations

import math
import textwrap
from collections.abc import Iterable
from typing import Any

import numpy as np

SINGLE_WIDTH_IN = 8.0
STRIP_IN = 0.6
"""A map drawn less high than this (inches) in a panel of a series is a strip (a corridor):
its panels are stacked, each as wide as a single picture."""
TEXT_IN = 0.5
"""The height (inches) of a panel's title and tick labels above and below a thin map."""
PANEL_WIDTH_IN = 3.6
TICKS_IN = 0.8
"""The width (inches) of a panel's y tick labels and label beside its map."""
NARROW_IN = (4.0, 2.0)
"""The least width (inches) of a single picture's panel and of a series' panels: a tall map
(a corridor along y) is drawn as wide as its height allows, with room for its title."""


def panel_height(drawn: float, low: float, least: float, most: float) -> float:
    """The height (inches) of a panel whose map is ``drawn`` inches high: at least ``low``,
    where its title, ticks and colour bar fit beside any map; a thin map (a long corridor)
    gets its own height and :data:`TEXT_IN` for the text instead (at least ``least``),
    not rows of white around a strip of map."""
    return float(np.clip(min(max(drawn, low), drawn + TEXT_IN), least, most))


def grid(n: int, aspect: float, group: int = 1) -> tuple[int, int, float, float]:
    """Rows, columns and panel size (inches) for ``n`` panels of height/width ``aspect``: one
    wide panel, or the column count that makes the page closest to 3:2 landscape (a
    multiple of ``group``, the levels of one time, so a row holds whole times)."""
    if n == 1:
        height = panel_height(SINGLE_WIDTH_IN * aspect, 2.5, 1.8, 9.0)
        return 1, 1, _narrowed(SINGLE_WIDTH_IN, height, aspect, NARROW_IN[0]), height
    if PANEL_WIDTH_IN * aspect < STRIP_IN:  # a strip: panels as wide as one picture, stacked
        cols = group if n <= 8 * group else 2 * group
        return math.ceil(n / cols), cols, SINGLE_WIDTH_IN, panel_height(
            SINGLE_WIDTH_IN * aspect, 1.4, 0.8, 5.0
        )
    height = panel_height(PANEL_WIDTH_IN * aspect, 1.4, 0.8, 5.0)
    width = _narrowed(PANEL_WIDTH_IN, height, aspect, NARROW_IN[1])

    def badness(cols: int) -> float:
        rows = math.ceil(n / cols)
        return abs(math.log(cols * width / (rows * height) / 1.5))

    cols = min(range(group, max(min(n, 6), group) + 1, group), key=badness)
    return math.ceil(n / cols), cols, width, height


def _narrowed(width: float, height: float, aspect: float, least: float) -> float:
    """A panel's width: ``width``, or for a map too tall to fill it at ``height`` inches (a
    corridor along y: a sliver in a page of white, its x tick labels run together) the
    map's own width and its y ticks', at least ``least``."""
    return float(np.clip(height / max(aspect, 1e-9) + TICKS_IN, least, width))


def wrapped(lines: Iterable[str], width_in: float, points: float) -> str:
    """``lines`` (empty ones left out) broken at spaces to fit ``width_in`` inches of text of
    ``points`` size: a narrow page (a tall map) cut a one-line legend or title at its edges."""
    chars = max(int(width_in * 72.0 / (0.6 * points)), 20)  # DejaVu Sans: ~0.55 em a character
    parts = [part for line in lines if line for part in line.split("\n")]  # its own breaks kept
    return "\n".join(textwrap.fill(part, chars) if part else part for part in parts)


def shortened(name: str, width: int) -> str:
    """``name`` on one line (runs of white space as one space), cut to ``width`` characters
    with a closing "…" when longer: at its last space past the middle, else within its last
    word (``textwrap.shorten`` keeps whole words only, and made a name without a space
    within the width a bare "…")."""
    text = " ".join(name.split())
    if len(text) <= width:
        return text
    cut = text[: width - 1]
    space = cut.rfind(" ")
    if space >= width // 2:
        cut = cut[:space]
    return cut.rstrip() + "…"


SETTLE_ROUNDS = 4
"""The most times :func:`settle` runs a figure's layout."""


def settle(fig: Any, rounds: int = SETTLE_ROUNDS) -> None:
    """Run the constrained layout of ``fig`` until its axes stop moving (at most ``rounds``
    times). A map panel keeps x and y on one scale, and the first layout of a fresh figure
    can leave too little room beside it: ETH's hotel (a tall map, its caption three lines)
    had its "y (m)" cut at the page's left edge, 4 pixels past it; two more layouts gave it
    the 5 pixels of margin every other picture has. A layout of 24 panels takes seconds, so
    it is run again only for a picture whose text was cut (:func:`text_cut_off`)."""
    engine = fig.get_layout_engine()
    if engine is None:
        return
    before = [ax.get_position(original=True).bounds for ax in fig.axes]
    for _ in range(rounds):
        engine.execute(fig)
        after = [ax.get_position(original=True).bounds for ax in fig.axes]
        if np.allclose(after, before, rtol=0.0, atol=1e-4):
            return
        before = after


def text_cut_off(fig: Any) -> bool:
    """Whether any text of the drawn ``fig`` (titles, axis labels, tick labels, the caption)
    reaches past the page's edges (half a pixel of rounding allowed)."""
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    texts = [getattr(fig, "_suptitle", None), getattr(fig, "_supxlabel", None)]
    for ax in fig.axes:
        texts += [ax.title, ax.xaxis.label, ax.yaxis.label]
        if not ax.axison:  # a row of legend or key over the panels: its ticks are not drawn
            continue
        for axis in (ax.xaxis, ax.yaxis):  # the labels of the ticks in view: those drawn
            lo, hi = sorted(axis.get_view_interval())
            texts += [label for loc, label in zip(axis.get_ticklocs(), axis.get_ticklabels(),
                                                  strict=False) if lo <= loc <= hi]
    for text in texts:
        if text is None or not text.get_visible() or not text.get_text():
            continue
        box = text.get_window_extent(renderer)
        if box.x0 < -0.5 or box.y0 < -0.5 or box.x1 > page.x1 + 0.5 or box.y1 > page.y1 + 0.5:
            return True
    return False
