"""The page of a top-down picture: how many rows and columns of panels, and how large
(inches), for the map's shape; a thin map (a corridor) gets no rows of white around it."""

from __future__ import annotations

import math

import numpy as np

SINGLE_WIDTH_IN = 8.0
STRIP_IN = 0.6
"""A map drawn less high than this (inches) in a panel of a series is a strip (a corridor):
its panels are stacked, each as wide as a single picture."""
TEXT_IN = 0.5
"""The height (inches) of a panel's title and tick labels above and below a thin map."""
PANEL_WIDTH_IN = 3.6


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
        return 1, 1, SINGLE_WIDTH_IN, panel_height(SINGLE_WIDTH_IN * aspect, 2.5, 1.8, 9.0)
    if PANEL_WIDTH_IN * aspect < STRIP_IN:  # a strip: panels as wide as one picture, stacked
        cols = group if n <= 8 * group else 2 * group
        return math.ceil(n / cols), cols, SINGLE_WIDTH_IN, panel_height(
            SINGLE_WIDTH_IN * aspect, 1.4, 0.8, 5.0
        )
    height = panel_height(PANEL_WIDTH_IN * aspect, 1.4, 0.8, 5.0)

    def badness(cols: int) -> float:
        rows = math.ceil(n / cols)
        return abs(math.log(cols * PANEL_WIDTH_IN / (rows * height) / 1.5))

    cols = min(range(group, max(min(n, 6), group) + 1, group), key=badness)
    return math.ceil(n / cols), cols, PANEL_WIDTH_IN, height
