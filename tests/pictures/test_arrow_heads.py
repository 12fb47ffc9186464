"""The arrows' heads: at most :data:`HEAD_SHARE` of an arrow's length, however short the arrow
is drawn. At matplotlib's one head length (4 shaft widths), the arrows of a merged map -- a
block of about 15 pixels, the shafts about 3 wide -- were all head. Measured on the polygons
matplotlib drew: how far each reaches along its direction, and where its head is widest."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from aion_cli.pictures.arrows import HEAD_LENGTH, HEAD_SHARE
from aion_cli.pictures.topdown import topdown_figure
from aion_cli.scene import Scene
from tests.pictures.pixels import cells_only_scene


def _grid(step: float, n: int) -> Any:
    xs, ys = np.meshgrid(np.arange(n) * step + 0.25, np.arange(n) * step + 0.25)
    return np.column_stack([xs.ravel(), ys.ravel()])


def _arrows(scene: Scene) -> tuple[Any, Any, Any, float]:
    """Each drawn arrow's length and head length (along its direction) and its shaft width,
    and the quiver's shaft width, in the quiver's units (a share of the panel's width)."""
    fig = topdown_figure([scene], ["panel"], dpi=120)
    fig.canvas.draw()
    (ax,) = [a for a in fig.axes if a.get_title() == "panel"]
    (quiver,) = [c for c in ax.collections if type(c).__name__ == "Quiver"]
    angle = np.arctan2(np.asarray(quiver.V), np.asarray(quiver.U))
    lengths, heads, shafts = [], [], []
    for path, a in zip(quiver.get_paths(), angle, strict=True):
        v = path.vertices
        along = v @ np.array([np.cos(a), np.sin(a)])
        across = v @ np.array([-np.sin(a), np.cos(a)])
        widest = np.abs(across) >= np.abs(across).max() - 1e-9  # the head's two corners
        lengths.append(along.max() - along.min())
        heads.append(along.max() - along[widest].mean())
        shafts.append(2.0 * np.abs(across[np.argmin(along)]))  # at the tail
    return np.array(lengths), np.array(heads), np.array(shafts), float(quiver.width)


def test_a_merged_maps_arrows_are_mostly_shaft() -> None:
    """2,500 cells 2 m apart over 100 m: the picture merges them over 2 m blocks, arrows
    about 17 pixels long at full flow; every head at most HEAD_SHARE of its arrow."""
    xy = _grid(2.0, 50)
    flows = np.linspace(0.3, 1.0, len(xy))
    angles = np.linspace(-np.pi, np.pi, len(xy))
    lengths, heads, shafts, width = _arrows(cells_only_scene(xy, flows, angles))
    assert len(lengths) == len(xy)
    assert (heads > 0).all()
    assert (heads <= HEAD_SHARE * lengths + 1e-9).all()
    # the busiest keep the picture's shaft width (a head from their length, not a thin copy
    # of a long arrow); a shorter arrow is a smaller copy of them, its shaft as much thinner
    busiest = lengths >= lengths.max() * (1 - 1e-9)
    assert shafts[busiest] == pytest.approx(np.full(busiest.sum(), width))
    assert shafts / lengths == pytest.approx(np.full(len(xy), width / lengths.max()))


def test_long_arrows_keep_their_head_size() -> None:
    """Arrows far apart (four cells long, many shaft widths): the head is HEAD_LENGTH shaft
    widths long whatever the arrow's length, well under HEAD_SHARE of it."""
    xy = _grid(4.0, 4)
    flows = np.linspace(2.0, 4.0, len(xy))
    lengths, heads, shafts, width = _arrows(cells_only_scene(xy, flows))
    assert shafts == pytest.approx(np.full(len(xy), width))
    assert (lengths > HEAD_LENGTH / HEAD_SHARE * shafts).all()
    assert heads == pytest.approx(HEAD_LENGTH * shafts)
    assert (heads < HEAD_SHARE * lengths).all()
