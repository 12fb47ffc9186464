"""The arrows' key (one reference arrow per figure, of a stated flow, in an empty corner) and
the margin around the map (as long as the longest arrow drawn, at least PAD_SHARE of the span;
no arrow runs out of the window). Read back from the artists matplotlib drew: the quiver's
vectors, the key's arrow polygon and text box, the axes' limits."""

from __future__ import annotations

import re
from typing import Any

import numpy as np
import pytest

from aion_cli.pictures.arrow_key import key_flow
from aion_cli.pictures.arrows import ARROW_CELLS
from aion_cli.pictures.topdown import topdown_figure
from aion_cli.pictures.view import PAD_SHARE
from aion_cli.scene import Scene
from tests.pictures.pixels import cells_only_scene

CELL = 0.5  # the cell edge of the synthetic scenes


def _grid(step: float, nx: int, ny: int) -> Any:
    xs, ys = np.meshgrid(np.arange(nx) * step + 0.25, np.arange(ny) * step + 0.25)
    return np.column_stack([xs.ravel(), ys.ravel()])


def _drawn(scenes: list[Scene]) -> tuple[Any, list[Any], list[Any]]:
    """The figure (drawn), its panels and the keys (``QuiverKey`` artists) of the figure."""
    fig = topdown_figure(scenes, [f"panel {i}" for i in range(len(scenes))], dpi=60)
    fig.canvas.draw()
    panels = [ax for ax in fig.axes if ax.get_title().startswith("panel")]
    from matplotlib.quiver import QuiverKey

    # in a panel's corner, or in a row of its own over the panels
    keys = [a for ax in fig.axes for a in ax.artists if isinstance(a, QuiverKey)]
    return fig, panels, keys


def _quiver(ax: Any) -> Any:
    (quiver,) = [c for c in ax.collections if type(c).__name__ == "Quiver"]
    return quiver


def _stated_flow(key: Any) -> float:
    """The flow the key's text states ("= 4.55 detections per 600-s window")."""
    match = re.match(r"= ([0-9.,]+) detections?\s+per 600-s window", key.text.get_text())
    assert match, key.text.get_text()
    return float(match.group(1).replace(",", ""))


def _extent_along(verts: Any, angle: float) -> float:
    """How far a drawn arrow polygon reaches along ``angle`` (its length, in its units)."""
    along = verts @ np.array([np.cos(angle), np.sin(angle)])
    return float(along.max() - along.min())


def test_the_key_is_as_long_as_an_arrow_of_its_stated_flow() -> None:
    xy = _grid(4.0, 4, 3)  # arrows far apart: drawn up to four cells long
    flows = np.linspace(1.0, 4.55, len(xy))
    angles = np.linspace(0.0, 1.5, len(xy))
    _, (ax,), (key,) = _drawn([cells_only_scene(xy, flows, angles)])
    stated = _stated_flow(key)
    assert stated == key_flow(4.55) == pytest.approx(4.55)  # the caption's "up to 4.55"
    quiver = _quiver(ax)
    metres = np.hypot(np.asarray(quiver.U), np.asarray(quiver.V))
    per_flow = metres / flows  # every arrow: length proportional to flow (none capped here)
    assert per_flow == pytest.approx(np.full(len(flows), ARROW_CELLS * CELL / 4.55))
    assert float(key.U) == pytest.approx(stated * per_flow[0])
    # the polygons drawn: the key's reaches as far, per flow, as the panel's arrows
    key_units = _extent_along(key.vector.get_paths()[0].vertices, 0.0)
    busiest = int(np.argmax(flows))
    arrow_units = _extent_along(quiver.get_paths()[busiest].vertices, angles[busiest])
    assert key_units / stated == pytest.approx(arrow_units / flows[busiest], rel=1e-6)


def test_the_key_and_the_caption_name_one_flow() -> None:
    """A busiest flow of 149.7: the caption states it to three digits ("150 detections"),
    and so does the key; rounded down to two digits the key said "= 140 detections" under a
    caption of "up to 150". Rounded up, the key's arrow is the full length (a busier entry's,
    capped), as long as the busiest arrow drawn."""
    from aion_cli.pictures.arrow_key import key_label
    from aion_cli.pictures.arrows import ArrowScale

    xy = _grid(4.0, 4, 3)
    flows = np.linspace(1.0, 149.7, len(xy))
    fig, (ax,), (key,) = _drawn([cells_only_scene(xy, flows)])
    assert _stated_flow(key) == 150.0
    caption = fig.get_supxlabel()
    assert "(the longest: 150 detections per 600-s window)" in caption, caption
    quiver = _quiver(ax)
    assert float(key.U) == pytest.approx(float(np.hypot(quiver.U, quiver.V).max()))
    # a scale below the largest flow: "up to 150" and "= 150"
    legend = ArrowScale(149.7, 900.0).legend(600.0)
    assert "up to 150 detections" in legend
    assert key_label(key_flow(149.7), 600.0).startswith("= 150 detections")
    assert key_flow(1234.5) == 1230.0  # the caption's "1,230", read back


def test_a_series_has_one_key_in_an_empty_corner() -> None:
    """An L of cells, the upper right empty: the key's text and arrow cover no cell."""
    xy = np.concatenate([_grid(CELL, 40, 4), _grid(CELL, 4, 40)])
    flows = np.linspace(1.0, 3.0, len(xy))
    scenes = [cells_only_scene(xy, flows), cells_only_scene(xy, flows[::-1])]
    fig, panels, keys = _drawn(scenes)
    assert len(keys) == 1
    key = keys[0]
    renderer = fig.canvas.get_renderer()
    corners = np.concatenate([xy + np.array([dx, dy]) for dx in (-0.25, 0.25)
                              for dy in (-0.25, 0.25)])
    pixels = panels[1].transData.transform(corners)  # every cell square's corners
    for box in (key.text.get_window_extent(renderer), key.vector.get_window_extent(renderer)):
        inside = (
            (pixels[:, 0] >= box.x0) & (pixels[:, 0] <= box.x1)
            & (pixels[:, 1] >= box.y0) & (pixels[:, 1] <= box.y1)
        )
        assert not inside.any()
        frame = panels[1].get_window_extent(renderer)
        assert frame.x0 <= box.x0
        assert box.x1 <= frame.x1
        assert frame.y0 <= box.y0
        assert box.y1 <= frame.y1


def test_no_arrows_no_key() -> None:
    xy = _grid(CELL, 4, 4)
    _, _, keys = _drawn([cells_only_scene(xy, np.zeros(len(xy)))])
    assert keys == []


def _window_checks(scene: Scene) -> tuple[float, float]:
    """The margin the window leaves beyond the cells and arrow ends, at most, and the margin
    it states (the longest arrow drawn, at least PAD_SHARE of the span); asserts that every
    arrow end lies in the window."""
    _, (ax,), _ = _drawn([scene])
    quiver = _quiver(ax)
    tails = np.asarray(quiver.XY)
    heads = tails + np.column_stack([np.asarray(quiver.U), np.asarray(quiver.V)])
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    for x, y in (tails.T, heads.T):
        assert ((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)).all()
    cells = scene.cells_xyz[:, :2]
    lo = np.minimum((cells - CELL / 2).min(axis=0), heads.min(axis=0))
    hi = np.maximum((cells + CELL / 2).max(axis=0), heads.max(axis=0))
    beyond = max(lo[0] - x0, x1 - hi[0], lo[1] - y0, y1 - hi[1])
    span = float(((cells + CELL / 2).max(axis=0) - (cells - CELL / 2).min(axis=0)).max())
    longest = float(np.hypot(np.asarray(quiver.U), np.asarray(quiver.V)).max())
    return beyond, max(longest, PAD_SHARE * span)


def test_a_dense_map_is_framed_by_its_shorter_arrows() -> None:
    """Cells side by side (a corridor's): arrows capped at twice their spacing, 1 m; the
    window leaves at most that beyond the cells, not four cells (2 m)."""
    xy = _grid(CELL, 30, 8)
    beyond, margin = _window_checks(cells_only_scene(xy, np.linspace(1.0, 5.0, len(xy))))
    assert margin == pytest.approx(2 * CELL)
    assert beyond <= margin + 1e-9
    assert beyond < ARROW_CELLS * CELL - 0.5


def test_arrows_pointing_out_of_the_map_stay_in_the_window() -> None:
    """Far-apart cells (arrows four cells long) on a map's edges, pointing outwards."""
    xy = _grid(4.0, 4, 4)
    centre = xy.mean(axis=0)
    angles = np.arctan2(*(xy - centre).T[::-1])
    beyond, margin = _window_checks(cells_only_scene(xy, np.full(len(xy), 2.0), angles))
    assert margin == pytest.approx(ARROW_CELLS * CELL)
    assert beyond <= margin + 1e-9


def _white_grounds(ax: Any) -> list[Any]:
    return [p for p in ax.patches if type(p).__name__ == "Rectangle"
            and tuple(p.get_facecolor()[:3]) == (1.0, 1.0, 1.0)]


def _cell_pixels(ax: Any, xy: Any) -> Any:
    """Every cell square's corners, in pixels of the drawn figure."""
    corners = np.concatenate([xy + np.array([dx, dy]) for dx in (-0.25, 0.25)
                              for dy in (-0.25, 0.25)])
    return ax.transData.transform(corners)


def _arrow_box(key: Any) -> Any:
    """The key's arrow polygon's box, in pixels: its vertices (in its quiver's units)
    through the quiver's scale, moved to the key's place."""
    from matplotlib.transforms import Bbox

    vector = key.vector
    at = vector.get_offset_transform().transform(vector.get_offsets())[0]
    xy = vector.get_transform().transform(vector.get_paths()[0].vertices) + at
    return Bbox([xy.min(axis=0), xy.max(axis=0)])


def _covers(box: Any, pixels: Any) -> bool:
    return bool(((pixels[:, 0] >= box.x0) & (pixels[:, 0] <= box.x1)
                 & (pixels[:, 1] >= box.y0) & (pixels[:, 1] <= box.y1)).any())


@pytest.mark.parametrize("panels", [1, 3])
def test_a_map_filling_every_corner_has_its_key_over_the_panels(panels: int) -> None:
    """A square of cells filling its window: every corner of the panel holds data. The key
    (a white ground under it covered the cells there) is drawn over the panels, outside every
    panel's frame and title, covering no cell, on the page, as long as a panel's arrow of its
    flow."""
    full = _grid(CELL, 30, 30)
    flows = np.linspace(1.0, 3.0, len(full))
    fig, axes, (key,) = _drawn([cells_only_scene(full, flows) for _ in range(panels)])
    renderer = fig.canvas.get_renderer()
    page = fig.bbox
    for ax in axes:
        assert _white_grounds(ax) == []
        frame = ax.get_window_extent(renderer)
        title = ax.title.get_window_extent(renderer)
        for box in (key.text.get_window_extent(renderer), _arrow_box(key)):
            assert not _covers(box, _cell_pixels(ax, full))
            assert not box.overlaps(frame)
            assert not box.overlaps(title)
            # on the page (half a pixel of rounding, as layout.text_cut_off allows)
            assert page.x0 - 0.5 <= box.x0
            assert box.x1 <= page.x1 + 0.5
            assert page.y0 - 0.5 <= box.y0
            assert box.y1 <= page.y1 + 0.5
    # its arrow as long, in pixels, as the busiest arrow times its flow's share
    quiver = _quiver(axes[-1])
    busiest = int(np.argmax(flows))
    arrow_px = _extent_along(
        quiver.get_paths()[busiest].vertices, 0.0
    ) * axes[-1].get_window_extent(renderer).width
    key_px = _arrow_box(key).width
    assert key_px == pytest.approx(arrow_px * _stated_flow(key) / flows[busiest], rel=0.02)


def test_a_key_in_a_corner_has_no_white_ground() -> None:
    xy = np.concatenate([_grid(CELL, 40, 4), _grid(CELL, 4, 40)])  # the upper right empty
    _, (ax,), (key,) = _drawn([cells_only_scene(xy, np.linspace(1.0, 3.0, len(xy)))])
    assert _white_grounds(ax) == []
    assert key in ax.artists


def test_a_key_in_a_left_corner_keeps_its_arrow_in_the_panel() -> None:
    """Cells everywhere but the lower left: the key goes there, text right of its arrow. The
    arrow's tip was at the corner's edge (quiverkey puts the tip at X for an eastward label),
    its shaft running left out of its box, over the frame."""
    xy = _grid(CELL, 40, 40)
    xy = xy[(xy[:, 0] > 10.0) | (xy[:, 1] > 10.0)]
    flows = np.linspace(1.0, 3.0, len(xy))
    fig, (ax,), (key,) = _drawn([cells_only_scene(xy, flows)])
    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    arrow, text = _arrow_box(key), key.text.get_window_extent(renderer)
    assert arrow.x1 <= text.x0  # the premise: the lower left, its text to the right
    assert arrow.y1 < frame.y0 + frame.height / 2
    for box in (arrow, text):
        assert not _covers(box, _cell_pixels(ax, xy))
        assert frame.x0 <= box.x0
        assert box.x1 <= frame.x1
        assert frame.y0 <= box.y0
