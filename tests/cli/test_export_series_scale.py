"""``aion export --from/--to``: the PLY frames of a series draw their spheres on one scale,
so a sphere that grows from one frame to the next is busier then (as the MCAP series and the
PNG small multiples share one scale); a map of hash cells only, whose cells carry the
arrows, sizes them on one scale too."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import open3d as o3d
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

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


def _quiet_and_busy_cells_csv() -> str:
    """Three days of a fixed sensor's tracks along +x through four hash cells (centres x =
    0.25 .. 1.75, y = 0.25): ten walkers every day at 08:00, one at 15:00."""
    rows = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    track = 0
    for day in range(3):
        for hour, walkers in ((8, 10), (15, 1)):
            for k in range(walkers):
                track += 1
                start = 1767571200 + day * 86400 + hour * 3600 + k * 300  # 2026-01-05 UTC
                rows += [f"{(start + s) * 10**9},{track},{0.25 + 0.5 * s},0.25,0,0,0.5"
                         for s in range(4)]  # fmt: skip
    return "\n".join(rows) + "\n"


def test_a_series_of_a_map_of_hash_cells_only_draws_its_arrows_on_one_scale(
    tmp_path: Path,
) -> None:
    """A map without places draws each cell's direction as an arrow as long as its flow
    (0.5 m cells: 0.5 * (0.8 + 2 * flow / scale) from the centre). The series' scale was
    taken from the nodes' flows only, so a map of cells only had none and every step drew
    its own busiest cell full length: 08:00 (ten walkers) and 15:00 (one) showed the same
    1.4 m arrows in the MCAP scene and the PLY frames. Now the quiet step's arrows are a
    tenth as busy, on the busy step's scale."""
    csv, log, out = tmp_path / "t.csv", tmp_path / "t.mcap", tmp_path / "t.aion"
    csv.write_text(_quiet_and_busy_cells_csv())
    observed = "2026-01-05 00:00..2026-01-08 00:00"
    assert run("convert", csv, "-o", log, "--observed", observed, "-q").exit_code == 0
    assert run("build", log, "-o", out, "-q").exit_code == 0
    when = ["--from", "2026-01-12 08:00", "--to", "2026-01-12 15:00", "--step", "7h"]
    scene = tmp_path / "s.mcap"
    done = run("export", out, *when, "--tz", "UTC", "-o", scene, "-q")
    assert done.exit_code == 0, done.stderr
    steps = []  # per step: (flow, arrow length) of each cell
    with scene.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _schema, _channel, _message, update in reader.iter_decoded_messages(
            topics=["/aion/scene"]
        ):
            steps.append([
                (float(next(m.value for m in e.metadata if m.key == "flow")),
                 e.arrows[0].shaft_length + e.arrows[0].head_length)
                for e in update.entities if e.arrows
            ])  # fmt: skip
    assert [len(s) for s in steps] == [4, 4]
    busy, quiet = (np.array(s) for s in steps)
    assert quiet[:, 0].max() < 0.2 * busy[:, 0].min()  # the premise: a busy and a quiet hour
    scale = busy[:, 0].max()
    for flow, length in np.concatenate([busy, quiet]):
        assert np.isclose(length, 0.5 * (0.8 + 2 * min(flow / scale, 1.0)))
    # the PLY frames: the arrows leave the last cell (x = 1.75) by the same lengths
    frames = tmp_path / "frames"
    done = run("export", out, *when, "--tz", "UTC", "-o", frames, "-q")
    assert done.exit_code == 0, done.stderr
    for folder, drawn in (("20260112T080000Z", busy), ("20260112T150000Z", quiet)):
        tips = np.asarray(o3d.io.read_triangle_mesh(str(frames / folder / "arrows.ply")).vertices)
        assert np.isclose(tips[:, 0].max() - 1.75, drawn[:, 1].max())
