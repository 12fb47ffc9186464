"""``aion export --from/--to``: the PLY frames of a series draw their spheres on one scale,
so a sphere that grows from one frame to the next is busier then (as the MCAP series and the
PNG small multiples share one scale)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tests.cli.conftest import run


def _sphere_radii_and_flows(frame: Path) -> tuple[np.ndarray, np.ndarray]:
    """Each node's sphere radius in ``frame/nodes.ply`` (read with a parser of its own: the
    header, then x, y, z as doubles and red, green, blue as bytes per vertex, the same number
    of vertices per sphere) and the node's flow in ``frame/entries.json``, matched by the
    sphere's centre and the entry's position."""
    data = (frame / "nodes.ply").read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").splitlines()
    properties = [line for line in header if line.startswith("property")]
    assert properties[:6] == [f"property double {c}" for c in "xyz"] + [
        f"property uchar {c}" for c in ("red", "green", "blue")
    ]
    (count,) = [int(line.split()[2]) for line in header if line.startswith("element vertex")]
    vertex = np.dtype([("xyz", "<f8", 3), ("rgb", "u1", 3)])
    xyz = np.frombuffer(data, vertex, count, end)["xyz"]
    nodes = [e for e in json.loads((frame / "entries.json").read_text())["entries"]
             if e["kind"] == "node"]  # fmt: skip
    spheres = xyz.reshape(len(nodes), count // len(nodes), 3)
    centres = spheres.mean(axis=1)
    radii = np.linalg.norm(spheres - centres[:, None, :], axis=2).max(axis=1)
    positions = np.array([[e["x"], e["y"], e["z"]] for e in nodes])
    nearest = np.linalg.norm(centres[:, None, :] - positions[None], axis=2).argmin(axis=1)
    assert sorted(nearest.tolist()) == list(range(len(nodes)))  # one sphere per node
    return radii, np.array([nodes[k]["flow"] for k in nearest])


def test_a_series_draws_every_frame_s_spheres_on_one_scale(
    sample_map: Path, tmp_path: Path
) -> None:
    """06:00 is quiet (its busiest place about 0.5 detections per window), 08:00 busy (about
    2.4): the quiet frame's busiest sphere was drawn full size like the busy frame's, so the
    frames disagreed on what a sphere's size means. Now a larger flow never has a smaller
    sphere, in any frame."""
    out = tmp_path / "series"
    result = run(
        "export", sample_map, "--from", "2026-01-07 06:00", "--to", "2026-01-07 08:00",
        "--step", "2h", "--tz", "UTC", "-o", out, "-q",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    quiet_r, quiet_flow = _sphere_radii_and_flows(out / "20260107T060000Z")
    busy_r, busy_flow = _sphere_radii_and_flows(out / "20260107T080000Z")
    assert quiet_flow.max() < 0.5 * busy_flow.max()  # the premise: a quiet and a busy hour
    assert quiet_r.max() < busy_r.max()
    radii = np.concatenate([quiet_r, busy_r])
    order = np.argsort(np.concatenate([quiet_flow, busy_flow]), kind="stable")
    assert (np.diff(radii[order]) >= -1e-9).all()


def test_a_series_of_one_time_draws_the_scene_of_that_time(
    sample_map: Path, tmp_path: Path
) -> None:
    """One time's scale is its own: the frame of ``--from T --to T`` is the ``--time T``
    scene, byte for byte."""
    at = "2026-01-07 06:00"
    series = run("export", sample_map, "--from", at, "--to", at, "-o", tmp_path / "s", "-q")
    single = run("export", sample_map, "--time", at, "-o", tmp_path / "t", "-q")
    assert series.exit_code == single.exit_code == 0, series.stderr + single.stderr
    frame = tmp_path / "s" / "20260107T060000Z"
    for name in ("nodes.ply", "arrows.ply", "scene.ply"):
        assert (frame / name).read_bytes() == (tmp_path / "t" / name).read_bytes()
