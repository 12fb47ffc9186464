"""The shape of a TF tree, for what aion says about it: frames with more than one parent,
the root a frame hangs from, and the transforms dropped as unusable, in words.

Pure functions of a buffer's edges (``(parent, child)`` pairs,
:attr:`formats.tf.TfBuffer.edges`); the buffer itself (:mod:`formats.tf`) interpolates and
composes.
"""

from __future__ import annotations

from collections.abc import Iterable

from aion_cli.listing import first_few


def parents(edges: Iterable[tuple[str, str]]) -> dict[str, list[str]]:
    """Each child frame's parents, sorted."""
    out: dict[str, set[str]] = {}
    for p, c in edges:
        out.setdefault(c, set()).add(p)
    return {c: sorted(ps) for c, ps in sorted(out.items())}


def extra_parents(edges: Iterable[tuple[str, str]]) -> dict[str, list[str]]:
    """Frames given more than one parent (a tree has one), with those parents."""
    return {c: ps for c, ps in parents(edges).items() if len(ps) > 1}


def root(edges: Iterable[tuple[str, str]], frame: str) -> str:
    """The frame at the top of ``frame``'s tree: parents followed up from ``frame`` (the
    first in name order where there are two) until a frame without one, or one already
    passed (a loop)."""
    up = parents(edges)
    seen = {frame}
    while up.get(frame):
        frame = up[frame][0]
        if frame in seen:
            break
        seen.add(frame)
    return frame


def unusable_text(unusable: dict[tuple[str, str], int], frame: str | None = None) -> str:
    """``unusable`` (:attr:`formats.tf.TfBuffer.unusable`) as ``3 of base_link->laser (a NaN
    or zero quaternion, or a non-finite translation)``; with ``frame``, only the edges that
    name it; "" when there are none."""
    edges = sorted((k, n) for k, n in unusable.items() if frame is None or frame in k)
    if not edges:
        return ""
    listed = first_few([f"{n:,} of {p}->{c}" for (p, c), n in edges], 5)
    return f"{listed} (a NaN or zero quaternion, or a non-finite translation)"
