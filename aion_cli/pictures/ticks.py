"""The x ticks of a map panel: as many as their labels fit side by side in the panel's width.

matplotlib's ``MaxNLocator("auto")`` sizes its tick count for labels about three characters
wide; a map in large absolute coordinates (UTM-like, x = 400 000 m) has six-digit labels,
and a small panel of a series ran "400000400020400040..." into one line. The map's own
coordinates stay on the ticks (no "+4e5" offset: ``draw_topdown``); there are fewer of them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.axis import Axis
from matplotlib.ticker import MaxNLocator

#: the steps a tick interval is made of, times a power of ten
STEPS = [1, 2, 2.5, 5, 10]
#: the width of a digit of the default font (DejaVu Sans: 0.636 em), a little over
DIGIT_EM = 0.65
#: the room between two labels (em)
GAP_EM = 1.0


class FittingLocator(MaxNLocator):
    """``MaxNLocator`` with at least one tick, and at most as many as the labels the
    formatter writes for them fit along the axis, each a gap apart."""

    def __init__(self) -> None:
        super().__init__("auto", steps=STEPS, min_n_ticks=1)

    def tick_values(self, vmin: float, vmax: float) -> Any:
        ticks = np.asarray(super().tick_values(vmin, vmax), dtype=np.float64)
        axis = self.axis
        if not isinstance(axis, Axis) or axis.axes is None:  # no panel to fit (a dummy axis)
            return ticks
        length = float(axis.axes.bbox.width)
        em = _label_points(axis) * float(getattr(axis.axes.figure, "dpi", 72.0)) / 72.0
        lo, hi = sorted((vmin, vmax))
        for nbins in range(max(len(ticks) - 1, 1), 0, -1):
            if nbins < len(ticks) - 1:
                fewer = MaxNLocator(nbins, steps=STEPS, min_n_ticks=1).tick_values(vmin, vmax)
                ticks = np.asarray(fewer, dtype=np.float64)
            shown = ticks[(ticks >= lo) & (ticks <= hi)]
            if _fits(axis, shown, length, em):
                break
        return ticks


def _label_points(axis: Any) -> float:
    """The size (points) of the axis's tick labels, without asking it for its ticks (which
    would call this locator again)."""
    from matplotlib import rcParams
    from matplotlib.font_manager import FontProperties

    size = rcParams["xtick.labelsize" if axis.axis_name == "x" else "ytick.labelsize"]
    return float(FontProperties(size=size).get_size_in_points())


def _fits(axis: Any, ticks: Any, length: float, em: float) -> bool:
    """Whether the labels of ``ticks`` fit side by side in ``length`` pixels."""
    if len(ticks) <= 1:
        return True
    formatter = axis.get_major_formatter()
    labels = formatter.format_ticks(list(np.asarray(ticks, dtype=np.float64)))
    widest = max(len(text) for text in labels) * DIGIT_EM + GAP_EM
    return bool(len(ticks) * widest * em <= length)
