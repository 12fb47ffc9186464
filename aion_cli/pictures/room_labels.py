"""The room labels of a top-down picture: at least :data:`ROOM_LABEL_POINTS` high, and none
over another.

A series' panels drew the rooms' names at 5.5 points, too small to read, and the office
sample's "office 1" and "office 2", two rooms 3 m apart, ran into each other at any size a
panel 3.6 inches wide could read. Now every label is :data:`ROOM_LABEL_POINTS` or larger; the
rooms with the most places are labelled first, and a label whose box (its text, estimated
generously, and its white halo) would overlap one already placed is shortened with a closing
"…" (down to :data:`SHORTEST` characters, and only while what it keeps begins no other room's
name: "meeti…" told none of six meeting rooms apart) until it fits, or left out; the
picture's legend says how many were shortened or left out (:func:`label_note`). Rooms are
few (at most :data:`.backdrop.MAX_ROOM_LABELS` are labelled): the labels are placed one by
one, each box checked against all placed before at once.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from aion_cli.pictures.backdrop import RoomOutlines
from aion_cli.pictures.layout import shortened

F64 = npt.NDArray[np.float64]

ROOM_LABEL_POINTS = 7.0
"""The least size (points) of a room's label, in one picture or a series' panels alike (the
legend's size; the series drew them at 5.5)."""
CHAR_EM = 0.62
"""A label character's width estimated, in em (DejaVu Sans averages about 0.55; generous,
since constrained layout draws a panel a little smaller than its slot)."""
LINE_EM = 1.2
"""A label's height, in em."""
HALO_POINTS = 2.5
"""The white halo round a label's letters (its stroke width, points)."""
SHORTEST = 4
"""A label is shortened to no fewer characters (its "…" included) before it is left out."""


@dataclass(frozen=True)
class FittedLabels:
    """The room outlines with the labels that fit (``rooms``), and how many labels were
    ``shortened`` and ``left_out``."""

    rooms: RoomOutlines
    shortened: int
    left_out: int


def label_boxes(xy: F64, chars: npt.NDArray[np.int64], points: float, per_inch: float) -> F64:
    """The boxes (x0, y0, x1, y1; metres) f64[n,4] of labels of ``chars`` characters centred
    at ``xy`` f64[n,2], ``points`` high, in a panel drawing ``per_inch`` metres an inch."""
    metres = points / 72.0 * per_inch  # one em
    halo = HALO_POINTS / 72.0 * per_inch
    half_w = (chars * CHAR_EM * metres + halo) / 2.0
    half_h = np.full(len(xy), (LINE_EM * metres + halo) / 2.0)
    return np.column_stack([xy[:, 0] - half_w, xy[:, 1] - half_h,
                            xy[:, 0] + half_w, xy[:, 1] + half_h])


def fit_labels(rooms: RoomOutlines, points: float, per_inch: float) -> FittedLabels:
    """``rooms`` with their labels at ``points`` (metres per inch of the panel: ``per_inch``)
    shortened or left out where they would overlap (the module docstring); the largest rooms
    (most places) first, ties in the rooms' order."""
    n = len(rooms.labels)
    if n == 0:
        return FittedLabels(rooms, 0, 0)
    weight = np.asarray(rooms.label_places or [0] * n, dtype=np.float64)
    order = np.argsort(-weight, kind="stable")
    names = [" ".join(label.split()) for label in rooms.labels]
    placed = np.zeros((0, 4))
    kept: dict[int, str] = {}
    cut = 0
    for i in order.tolist():  # one room at a time (at most MAX_ROOM_LABELS)
        text = names[i]
        options = [text] + [
            cut_text for k in range(len(text) - 1, SHORTEST - 1, -1)
            if _telling(cut_text := shortened(text, k), names)
        ]
        boxes = label_boxes(
            np.repeat(rooms.label_xy[i : i + 1], len(options), axis=0),
            np.array([len(o) for o in options], dtype=np.int64), points, per_inch,
        )
        clear = ~(
            (boxes[:, None, 0] < placed[None, :, 2]) & (boxes[:, None, 2] > placed[None, :, 0])
            & (boxes[:, None, 1] < placed[None, :, 3]) & (boxes[:, None, 3] > placed[None, :, 1])
        ).any(axis=1)
        if not clear.any():
            continue
        first = int(np.argmax(clear))  # the longest that fits
        kept[i] = options[first]
        cut += first > 0
        placed = np.vstack([placed, boxes[first]])
    keep = sorted(kept)
    fitted = replace(
        rooms,
        label_xy=rooms.label_xy[keep].reshape(-1, 2),
        labels=tuple(kept[i] for i in keep),
        label_places=tuple(rooms.label_places[i] for i in keep) if rooms.label_places else (),
    )
    return FittedLabels(fitted, cut, n - len(keep))


def _telling(cut: str, names: list[str]) -> bool:
    """Whether the shortened label ``cut`` (ending "…") still tells its room from the others:
    no other name of ``names`` begins with what it keeps ("meeti…" of "meeting room 2" named
    all six meeting rooms alike)."""
    stem = cut[:-1].rstrip()
    return sum(name.startswith(stem) for name in names) == 1


def label_note(fitted: FittedLabels) -> str:
    """The legend's line on the labels that did not fit ("" when all did)."""
    parts = []
    if fitted.shortened:
        parts.append(f"{fitted.shortened} shortened")
    if fitted.left_out:
        parts.append(f"{fitted.left_out} left out")
    if not parts:
        return ""
    total = len(fitted.rooms.labels) + fitted.left_out
    return (
        f"room labels: {' and '.join(parts)} of {total}, where they would run into "
        "another (the rooms with most places labelled first)"
    )


def map_per_inch(x_span: float, y_span: float, panel_in: tuple[float, float]) -> float:
    """The metres an inch of a panel ``panel_in`` (width, height; inches, its slot on the
    page) draws a map of ``x_span`` by ``y_span`` metres at, x and y on one scale: the slot
    less its tick labels and title (:data:`.layout.TICKS_IN`, :data:`.layout.TEXT_IN`),
    which constrained layout takes from it."""
    from aion_cli.pictures.layout import TEXT_IN, TICKS_IN

    width = max(panel_in[0] - TICKS_IN, 0.5 * panel_in[0])
    height = max(panel_in[1] - TEXT_IN, 0.5 * panel_in[1])
    return max(x_span / width, y_span / height)
