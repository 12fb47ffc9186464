"""How long the arrows of a top-down picture are drawn: the busiest :data:`ARROW_CELLS` cells
long where the arrows are far apart, at most :data:`REACH` times their spacing where they are
close (cells 0.5 m apart, as the Lincoln corridor's: the busiest arrows, 2 m long, crossed
three or four of their neighbours), never under :data:`MIN_ARROW_CELLS` cells; the legend
says so. The lengths are read back from the quiver matplotlib drew."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from aion_cli.pictures.arrows import (
    ARROW_CELLS,
    MIN_ARROW_CELLS,
    REACH,
    arrow_field,
    arrow_spacing,
)
from aion_cli.pictures.topdown import topdown_figure
from aion_cli.scene import Scene
from tests.pictures.pixels import cells_only_scene, synthetic_scene

CELL = 0.5  # the cell edge of the synthetic scenes


def _grid(step: float, nx: int = 16, ny: int = 6) -> Any:
    """Cell centres ``step`` metres apart, ``nx`` by ``ny``."""
    xs, ys = np.meshgrid(np.arange(nx) * step + 0.25, np.arange(ny) * step + 0.25)
    return np.column_stack([xs.ravel(), ys.ravel()])


def _drawn_lengths(scenes: list[Scene]) -> tuple[list[Any], str]:
    """The arrow lengths (m) of each panel as matplotlib draws them, and the caption."""
    fig = topdown_figure(scenes, [f"panel {i}" for i in range(len(scenes))], dpi=60)
    panels = [ax for ax in fig.axes if ax.get_title().startswith("panel")]
    lengths = []
    for ax in panels:
        (quiver,) = [c for c in ax.collections if type(c).__name__ == "Quiver"]
        lengths.append(np.hypot(np.asarray(quiver.U), np.asarray(quiver.V)))
    return lengths, fig._supxlabel.get_text()


def _flows(n: int) -> Any:
    """Flows 1..n, the busiest n: linear arrows up to it (no quantile cut below 20 flows
    of even spread)."""
    return np.arange(1.0, n + 1.0)


def test_arrows_far_apart_keep_their_full_length() -> None:
    xy = _grid(4.0, 4, 3)  # 4 m apart: twice that is longer than four cells
    (lengths,), caption = _drawn_lengths([cells_only_scene(xy, _flows(len(xy)))])
    assert lengths.max() == pytest.approx(ARROW_CELLS * CELL)
    assert "the longest arrow drawn" not in caption


def test_arrows_of_neighbouring_cells_are_no_longer_than_twice_their_spacing() -> None:
    xy = _grid(CELL)  # cells side by side, as a corridor's: 0.5 m apart
    n = len(xy)
    (lengths,), caption = _drawn_lengths([cells_only_scene(xy, _flows(n))])
    assert REACH * CELL < ARROW_CELLS * CELL  # the case in question: the cap is shorter
    assert lengths.max() == pytest.approx(REACH * CELL)
    # still proportional to flow: the arrow of flow k is k/n of the longest
    assert np.sort(lengths) == pytest.approx(REACH * CELL * _flows(n) / n)
    assert "the longest arrow drawn 1 m long, 2 times the arrows' typical spacing (0.5 m)" in (
        " ".join(caption.split())
    )


def test_arrows_packed_closer_than_a_cell_are_still_two_cells_long() -> None:
    xy = _grid(0.2)  # places 0.2 m apart (a house's Hydra places): twice that is under 2 cells
    (lengths,), caption = _drawn_lengths([cells_only_scene(xy, _flows(len(xy)))])
    assert lengths.max() == pytest.approx(MIN_ARROW_CELLS * CELL)
    assert "the longest arrow drawn 1 m long (2 cells; the arrows are typically 0.2 m apart)" in (
        " ".join(caption.split())
    )


def test_the_panels_of_a_series_share_one_length() -> None:
    """Two times of one map: at the first, only every other cell of a row flows (1 m
    apart), at the second, the cells between (1 m apart too): the tails of both, together,
    are 0.5 m apart, and both panels draw their busiest arrow that long times two, so that
    an arrow's length means one flow across the series."""
    xy = _grid(CELL, 16, 1)
    even = np.arange(len(xy)) % 2 == 0
    first = cells_only_scene(xy, np.where(even, 1.0, 0.0))
    second = cells_only_scene(xy, np.where(even, 0.0, 1.0))
    assert arrow_spacing([arrow_field(first)]) == pytest.approx(2 * CELL)
    assert arrow_spacing([arrow_field(first), arrow_field(second)]) == pytest.approx(CELL)
    lengths, _ = _drawn_lengths([first, second])
    assert [float(x.max()) for x in lengths] == pytest.approx([REACH * CELL] * 2)


def test_no_spacing_for_merged_arrows_or_a_single_one() -> None:
    assert arrow_spacing([arrow_field(synthetic_scene(), block=2.0)]) is None
    one = cells_only_scene(np.array([[0.0, 0.0]]), np.array([1.0]))
    assert arrow_spacing([arrow_field(one)]) is None
    field = replace(arrow_field(one), spacing=None)
    assert field.full_length(CELL) == ARROW_CELLS * CELL
    assert field.length_note(CELL) == ""
