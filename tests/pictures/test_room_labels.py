"""The room labels of a top-down picture: readable (at least ROOM_LABEL_POINTS, a series'
panels too: they were 5.5 points) and none over another (shortened with "…" or left out,
the largest rooms first; the legend says how many). Read back from the texts matplotlib drew:
their sizes and their boxes on the page."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from aion_cli.pictures.room_labels import ROOM_LABEL_POINTS
from aion_cli.pictures.topdown import topdown_figure
from aion_cli.scene import Scene
from tests.pictures.pixels import synthetic_scene

SMALL = tuple(f"meeting room {k}" for k in range(1, 7))
BIG = ("open-plan workspace", "hallway")


def _office() -> Scene:
    """An office 40 m wide: a workspace of 72 places, a hallway of 40 in a row, and six small
    rooms of two places each, 4 m apart, whose names ("meeting room 1", ...) are longer than
    that at a readable size in a panel of a series."""
    work = [(x, y) for x in np.arange(1.0, 24.0, 2.0) for y in np.arange(1.0, 13.0, 2.0)]
    hall = [(x, 15.5) for x in np.arange(0.5, 40.0, 1.0)]
    small = [(x + dx, 20.0) for x in np.arange(3.0, 25.0, 4.0) for dx in (-0.5, 0.5)]
    xy = np.array(work + hall + small)
    room = np.r_[np.zeros(len(work)), np.ones(len(hall)), 2 + np.arange(len(small)) // 2]
    n, rooms = len(xy), 2 + len(SMALL)
    xyz = np.column_stack([xy, np.zeros(n)])
    return replace(
        synthetic_scene(),
        node_ids=np.arange(n, dtype=np.uint64),
        nodes_xyz=xyz,
        node_flow=np.ones(n),
        node_entropy=np.full(n, 0.3),
        node_angle=np.zeros(n),
        node_concentration=np.full(n, 0.9),
        places_xyz=xyz,
        edges_xyz=np.zeros((0, 2, 3)),
        place_room=room.astype(np.int64),
        room_ids=np.arange(rooms, dtype=np.uint64) | np.uint64(ord("R") << 56),
        room_labels=(*BIG, *SMALL),
        room_xyz=np.zeros((rooms, 3)),
        mesh=None,
    )


def _labels(fig: Any) -> list[list[Any]]:
    """The room labels (texts) of each panel, after drawing."""
    fig.canvas.draw()
    panels = [ax for ax in fig.axes if ax.get_title().startswith("panel")]
    return [list(ax.texts) for ax in panels]


def _overlapping(boxes: list[Any]) -> list[tuple[int, int]]:
    return [(i, j) for i in range(len(boxes)) for j in range(i + 1, len(boxes))
            if boxes[i].overlaps(boxes[j])]


def _is_label(text: str) -> bool:
    """A whole room name, or one cut with a closing "…"."""
    names = (*BIG, *SMALL)
    return text in names or (text.endswith("…") and any(
        n.startswith(text[:-1].rstrip()) for n in names))


def test_a_series_labels_rooms_readably_and_apart() -> None:
    scene = _office()
    fig = topdown_figure([scene, scene, scene], ["panel 0", "panel 1", "panel 2"], dpi=100)
    per_panel = _labels(fig)
    renderer = fig.canvas.get_renderer()
    caption = fig._supxlabel.get_text()
    for texts in per_panel:
        assert all(t.get_fontsize() >= ROOM_LABEL_POINTS for t in texts)
        shown = [t.get_text() for t in texts]
        assert all(_is_label(s) for s in shown), shown
        assert set(BIG) <= set(shown)  # the largest rooms first, whole
        assert len(shown) < len(BIG) + len(SMALL)  # the premise: they did not all fit
        boxes = [t.get_window_extent(renderer) for t in texts]
        assert _overlapping(boxes) == []
        assert shown == [t.get_text() for t in per_panel[0]]  # every panel alike
    left = len(BIG) + len(SMALL) - len(per_panel[0])
    cut = sum(s.get_text().endswith("…") for s in per_panel[0])
    assert f"{left} left out of {len(BIG) + len(SMALL)}" in " ".join(caption.split())
    if cut:
        assert f"{cut} shortened" in caption


def test_labels_that_fit_are_drawn_whole_without_a_note() -> None:
    """One picture 8 inches wide of the two large rooms alone: both whole, no note."""
    scene = _office()
    keep = scene.place_room < 2
    few = replace(
        scene, places_xyz=scene.places_xyz[keep], nodes_xyz=scene.nodes_xyz[keep],
        node_ids=scene.node_ids[keep], node_flow=scene.node_flow[keep],
        node_entropy=scene.node_entropy[keep], node_angle=scene.node_angle[keep],
        node_concentration=scene.node_concentration[keep], place_room=scene.place_room[keep],
        room_ids=scene.room_ids[:2], room_labels=BIG, room_xyz=scene.room_xyz[:2],
    )
    fig = topdown_figure([few], ["panel 0"], dpi=100)
    (texts,) = _labels(fig)
    assert sorted(t.get_text() for t in texts) == sorted(BIG)
    assert all(t.get_fontsize() >= ROOM_LABEL_POINTS for t in texts)
    assert "room labels" not in fig._supxlabel.get_text()


def test_a_label_is_shortened_to_the_longest_that_fits_and_still_tells_its_room() -> None:
    """Two rooms side by side: the larger keeps its name; the smaller's is cut to the longest
    "…" form whose box clears the first (one more character would not), while a name that
    begins another's ("meeting room 2" beside "meeting room 1") is left out, not cut to a
    "meeting…" that names both."""
    from aion_cli.pictures.backdrop import RoomOutlines
    from aion_cli.pictures.room_labels import fit_labels, label_boxes

    def boxes(xy: Any, texts: list[str]) -> Any:
        chars = np.array([len(t) for t in texts], dtype=np.int64)
        return label_boxes(np.asarray(xy, float).reshape(-1, 2), chars, 7.0, 1.0)

    def apart(a: Any, b: Any) -> bool:
        return bool(a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1])

    first = boxes([[0.0, 0.0]], ["workspace"])[0]
    dx = first[2] + 0.5 * (boxes([[0.0, 0.0]], ["x" * 10])[0][2] * 2) + 1e-3
    rooms = RoomOutlines((), np.array([[0.0, 0.0], [dx, 0.0]]),
                         ("workspace", "laboratory of robotics"), (10, 1))
    fitted = fit_labels(rooms, 7.0, 1.0)
    whole, cut = fitted.rooms.labels
    assert whole == "workspace"
    assert cut.endswith("…")
    assert "laboratory of robotics".startswith(cut[:-1])
    assert apart(first, boxes([[dx, 0.0]], [cut])[0])
    assert not apart(first, boxes([[dx, 0.0]], [cut + "x"])[0])  # the longest that fits
    assert (fitted.shortened, fitted.left_out) == (1, 0)
    twins = RoomOutlines((), np.array([[0.0, 0.0], [dx, 0.0]]),
                         ("meeting room 1", "meeting room 2"), (10, 1))
    fitted = fit_labels(twins, 7.0, 1.0)
    assert fitted.rooms.labels == ("meeting room 1",)
    assert (fitted.shortened, fitted.left_out) == (0, 1)
