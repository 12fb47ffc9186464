"""The node and arrow markers of ``export --format mcap`` written a few byte operations per
marker (:func:`formats.scene_markers._texted`) are the bytes :func:`_marker` writes for each,
whatever the ids' lengths (every padding case) and wherever a marker starts."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest

from aion_cli.formats import scene_markers
from aion_cli.formats.scene_markers import _IDENTITY, ARROW, SPHERE, _Cdr, _marker
from aion_cli.formats.scene_style import style_scene
from tests.formats.test_scene_mcap import (
    CELL_ENTROPY,
    CELL_FLOW,
    CELL_IDS,
    CELLS,
    DELTA,
    MESH,
    T0,
)


def _reference(
    out: _Cdr,
    header: tuple[int, int, str],
    ns: str,
    kind: int,
    ids: Sequence[int],
    poses: Sequence[Sequence[float]],
    colors: Sequence[Sequence[float]],
    texts: Sequence[str],
) -> None:
    """The loop marker_array ran before: one _marker call per node or arrow."""
    for marker_id, pose, color, text in zip(ids, poses, colors, texts, strict=True):
        _marker(out, header, ns, marker_id, kind, pose[:7], pose[7:], color, text=text)


@pytest.mark.parametrize("seed", range(6))
def test_texted_equals_one_marker_each(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 60))
    xyz = rng.uniform(-20, 20, (n, 3))
    flow = rng.uniform(0, 5, n) * (rng.random(n) < 0.8)
    angle = np.where(rng.random(n) < 0.7, rng.uniform(-np.pi, np.pi, n), np.nan)
    ids = ["".join(rng.choice(list("pcRé0123456789"), int(rng.integers(0, 12)))) for _ in range(n)]
    edges = np.stack([xyz[:-1], xyz[1:]], axis=1) if n > 1 else None
    style = style_scene(
        xyz, flow, rng.uniform(0, 1, n), angle, CELLS, CELL_FLOW, CELL_ENTROPY, edges,
        MESH if seed % 2 else None, xyz[: min(n, 3)] if seed % 3 else None, DELTA,
    )
    fast = scene_markers.marker_array(T0 + seed * 7, style, ids, CELL_IDS)
    monkeypatch.setattr(scene_markers, "_texted", _reference)
    assert fast == scene_markers.marker_array(T0 + seed * 7, style, ids, CELL_IDS)


@pytest.mark.parametrize("lead", range(8))
@pytest.mark.parametrize("kind", [SPHERE, ARROW])
@pytest.mark.parametrize("frame", ["map", "odom", "right_laser"])  # the map's frame
def test_any_start_offset(lead: int, kind: int, frame: str) -> None:
    texts = ["", "a", "ab", "abc", "abcd", "p12345", "é"]
    poses = [(1.0 * k, 2.0, 3.0, *_IDENTITY, 0.5, 0.25, 0.125) for k in range(len(texts))]
    colors = [(0.1 * k, 0.2, 0.3) for k in range(len(texts))]
    ids = list(range(3, 3 + len(texts)))
    fast, slow = _Cdr(), _Cdr()
    fast.buf += bytes(lead)
    slow.buf += bytes(lead)
    scene_markers._texted(fast, (5, 6, frame), "nodes", kind, ids, poses, colors, texts)
    _reference(slow, (5, 6, frame), "nodes", kind, ids, poses, colors, texts)
    assert fast.buf == slow.buf
