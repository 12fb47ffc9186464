"""``aion export --format mcap``: a day series of the sample map read back with the Foxglove
protobuf and mcap-ros2 decoders and compared with ``aion predict`` / ``aion plan``; the API's
``Map.export(format="mcap")``; bad outputs (``aion info`` on such a scene:
``test_export_mcap_info.py``)."""

from __future__ import annotations

import importlib.abc
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory as Ros2Decoders

import aion_cli as aion
from aion_cli.timeparse import parse_time, resolve_zone
from tests.cli.conftest import Office, assert_one_line_error, run, run_json

TIMES = ["2026-01-12 07:00", "2026-01-12 08:00", "2026-01-12 09:00"]
UTC = resolve_zone("UTC")


def series_args(map_path: Path, out: Path, *extra: str) -> list[str | Path]:
    return [
        "export",
        map_path,
        "--from",
        TIMES[0],
        "--to",
        TIMES[-1],
        "--step",
        "1h",
        "--tz",
        "UTC",
        "--format",
        "mcap",
        "-o",
        out,
        *extra,
    ]


def scene_updates(path: Path) -> list[tuple[int, Any]]:
    """(log time, SceneUpdate) per message of /aion/scene, parsed from the raw bytes."""
    with path.open("rb") as fh:
        return [
            (m.log_time, SceneUpdate.FromString(m.data))
            for _, _, m in make_reader(fh).iter_messages(topics=["/aion/scene"])
        ]


def ros_messages(path: Path, topic: str) -> list[Any]:
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[Ros2Decoders()])
        return [d for _, _, _, d in reader.iter_decoded_messages(topics=[topic])]


@pytest.fixture(scope="module")
def series(sample_map: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("mcap") / "day.mcap"
    result = run(*series_args(sample_map, out, "--path-from", "p103", "--path-to", "p2"))
    assert result.exit_code == 0, result.stderr
    assert "day.mcap" in result.stderr  # the summary goes to stderr
    return out


@pytest.fixture(scope="module")
def predicted(sample_map: Path) -> list[dict[str, Any]]:
    """``aion predict --format json`` entries at each time of the series, by id."""
    return [
        {
            e["id"]: e
            for e in run_json(
                "predict", sample_map, "--time", t, "--tz", "UTC", "--format", "json"
            )["entries"]
        }
        for t in TIMES
    ]


def test_one_scene_per_step_at_its_time(series: Path) -> None:
    updates = scene_updates(series)
    assert [t for t, _ in updates] == [parse_time(t, UTC) for t in TIMES]
    assert len(ros_messages(series, "/aion/markers")) == len(TIMES)


def test_entities_are_the_entries_of_predict(series: Path, predicted: list[dict[str, Any]]) -> None:
    ids_per_step = []
    for (_, update), entries in zip(scene_updates(series), predicted, strict=True):
        spheres = [e.id for e in update.entities if e.spheres]
        cubes = [e.id for e in update.entities if e.cubes]
        assert sorted(spheres) == sorted(i for i, e in entries.items() if e["kind"] == "node")
        assert sorted(cubes) == sorted(i for i, e in entries.items() if e["kind"] == "cell")
        # 2 cells with people, 3 the scene graph released (places merged away by loop
        # closures, which the robot had watched empty: their entries go to the hash cells)
        assert len(cubes) == 5
        assert all(len(e.spheres) == 1 for e in update.entities if e.spheres)
        for entity in update.entities:
            if entity.spheres or entity.cubes:
                meta = {m.key: m.value for m in entity.metadata}
                flow = entries[entity.id]["flow"]
                assert float(meta["flow"]) == pytest.approx(flow, rel=1e-3, abs=1e-12)
        ids_per_step.append([e.id for e in update.entities])
    assert ids_per_step[0] == ids_per_step[1] == ids_per_step[2]
    assert {"aion/edges", "aion/mesh", "aion/path"} <= set(ids_per_step[0])


def test_every_entity_carries_the_direction_of_predict(
    series: Path, predicted: list[dict[str, Any]]
) -> None:
    """Nodes and hash cells alike carry ``direction_deg`` (the README's "flow, entropy and
    direction as metadata"): a cell's was left out."""
    with_direction = 0
    for (_, update), entries in zip(scene_updates(series), predicted, strict=True):
        for entity in update.entities:
            if not (entity.spheres or entity.cubes):
                continue
            meta = {m.key: m.value for m in entity.metadata}
            want = entries[entity.id]["direction_deg"]
            if want is None:
                assert meta["direction_deg"] == "null", entity.id
            else:
                assert float(meta["direction_deg"]) == pytest.approx(want, abs=0.01), entity.id
                with_direction += bool(entity.cubes)
    assert with_direction >= 2  # the two cells with people


def test_colours_follow_entropy_and_sizes_follow_flow(
    series: Path, predicted: list[dict[str, Any]], sample_map: Path
) -> None:
    delta = aion.Map.load(sample_map).config.cell_size
    node_flows = [
        e["flow"] or 0.0 for step in predicted for e in step.values() if e["kind"] == "node"
    ]
    scale = max(node_flows)  # one scale for the whole series
    for (_, update), entries in zip(scene_updates(series), predicted, strict=True):
        nodes = [e for e in update.entities if e.spheres]
        entropy = {e.id: entries[e.id]["entropy"] for e in nodes}
        known = [e for e in nodes if entropy[e.id] is not None]
        reddest = max(known, key=lambda e: e.spheres[0].color.r - e.spheres[0].color.b)
        assert entropy[reddest.id] == max(entropy[e.id] for e in known)
        for e in known:
            c = e.spheres[0].color
            assert (c.r, c.g, c.b) == pytest.approx((entropy[e.id], 0.0, 1.0 - entropy[e.id]))
        flow = np.array([entries[e.id]["flow"] or 0.0 for e in nodes])
        size = np.array([e.spheres[0].size.x for e in nodes])
        np.testing.assert_allclose(size, 2 * delta * (0.2 + 0.8 * np.minimum(flow / scale, 1)))
        order = np.argsort(flow, kind="stable")
        assert np.all(np.diff(size[order]) >= 0)
    biggest = max(
        e.spheres[0].size.x for _, u in scene_updates(series) for e in u.entities if e.spheres
    )
    assert biggest == pytest.approx(2 * delta)  # the busiest node of the day at full size


def test_markers_have_the_same_content(series: Path) -> None:
    for (_, update), markers in zip(
        scene_updates(series), ros_messages(series, "/aion/markers"), strict=True
    ):
        assert markers.markers[0].action == 3  # DELETEALL first
        nodes = [m for m in markers.markers if m.ns == "nodes"]
        spheres = {e.id: e.spheres[0] for e in update.entities if e.spheres}
        assert [m.text for m in nodes] == list(spheres)
        assert [m.id for m in nodes] == list(range(len(nodes)))
        for m in nodes:
            assert m.scale.x == pytest.approx(spheres[m.text].size.x)
            assert m.color.r == pytest.approx(spheres[m.text].color.r, abs=1e-6)
        arrows = [m.text for m in markers.markers if m.ns == "arrows"]
        assert arrows == [e.id for e in update.entities if e.arrows]
        (cells,) = [m for m in markers.markers if m.ns == "cells"]
        assert len(cells.points) == sum(1 for e in update.entities if e.cubes)
        assert {m.ns for m in markers.markers} == {
            "",
            "nodes",
            "arrows",
            "cells",
            "edges",
            "mesh",
            "path",
        }
    (tf,) = ros_messages(series, "/tf_static")
    assert [(t.header.frame_id, t.child_frame_id) for t in tf.transforms] == [("world", "map")]


def test_the_path_is_the_plan_at_each_step(
    series: Path, sample_map: Path, predicted: list[dict[str, Any]]
) -> None:
    for (_, update), t, entries in zip(scene_updates(series), TIMES, predicted, strict=True):
        plan = run_json(
            "plan", sample_map, "--from", "p103", "--to", "p2", "--time", t, "--tz", "UTC",
            "--format", "json",
        )  # fmt: skip
        (path,) = [e.lines[0] for e in update.entities if e.id == "aion/path"]
        points = [(p.x, p.y, p.z) for p in path.points]
        nodes = plan["temporal"]["path"]
        assert len(points) == len(nodes)
        want = [(entries[n]["x"], entries[n]["y"], entries[n]["z"]) for n in nodes]
        np.testing.assert_allclose(points, want, atol=1e-6)


def test_no_path_historical_and_the_api(sample_map: Path, tmp_path: Path) -> None:
    out = tmp_path / "hist.mcap"
    result = run("export", sample_map, "--historical", "--format", "mcap", "-o", out)
    assert result.exit_code == 0, result.stderr
    ((log_time, update),) = scene_updates(out)
    assert log_time == aion.Map.load(sample_map).manifest.end_ns  # the end of the map's data
    ids = [e.id for e in update.entities]
    assert "aion/path" not in ids
    history = run_json("predict", sample_map, "--historical", "--format", "json")["entries"]
    assert sorted(i for i in ids if not i.startswith("aion/")) == sorted(e["id"] for e in history)
    # the API writes the same scene as the CLI
    cli = tmp_path / "cli.mcap"
    run("export", sample_map, "--time", TIMES[1], "--tz", "UTC", "--format", "mcap", "-o", cli)
    files = aion.Map.load(sample_map).export(
        tmp_path / "api.mcap", time=TIMES[1], tz="UTC", format="mcap"
    )
    assert files == [tmp_path / "api.mcap"]
    assert scene_updates(files[0]) == scene_updates(cli)


def test_existing_mcap_is_replaced_other_files_refused(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "scene.mcap"
    for _ in range(2):  # the second run replaces the first file
        result = run("export", office.map, "--historical", "--format", "mcap", "-o", out)
        assert result.exit_code == 0, result.stderr
    assert len(scene_updates(out)) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.mcap"]
    notes = tmp_path / "notes.mcap"
    notes.write_text("keep me")
    result = run("export", office.map, "--historical", "--format", "mcap", "-o", notes)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "not an MCAP scene aion wrote")
    assert notes.read_text() == "keep me"


@pytest.mark.parametrize(
    ("target", "fragment"),
    [
        ("folder", "is a folder"),
        ("scene.ply", "the format mcap and the name"),
        ("blocker/scene.mcap", "cannot write"),
    ],
)
def test_bad_outputs(office: Office, tmp_path: Path, target: str, fragment: str) -> None:
    (tmp_path / "folder").mkdir()
    (tmp_path / "folder" / "keep.txt").write_text("x")
    (tmp_path / "blocker").write_text("a file where a folder is needed")
    result = run(
        "export", office.map, "--time", "2026-11-23 08:30", "--format", "mcap",
        "-o", tmp_path / target,
    )  # fmt: skip
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, fragment)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker", "folder"]
    assert [p.name for p in (tmp_path / "folder").iterdir()] == ["keep.txt"]


def test_bad_path_ids_fail_before_writing(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    result = run(
        "export", office.map, "--time", "2026-11-23 08:30", "--format", "mcap", "-o", out,
        "--path-from", "p0", "--path-to", "p77",
    )  # fmt: skip
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "p77")
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


class _NoOpen3d(importlib.abc.MetaPathFinder):
    """A core install: the ``export`` extra (open3d) is not there."""

    def find_spec(self, fullname: str, path: object, target: object = None) -> None:
        if fullname == "open3d" or fullname.startswith("open3d."):
            raise ModuleNotFoundError(f"No module named {fullname!r}", name=fullname)


def test_mcap_needs_no_open3d(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A core install (no ``aion[export]``) writes MCAP scenes: only PLY/PCD need open3d."""
    for name in [n for n in sys.modules if n == "open3d" or n.startswith("open3d.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setattr(sys, "meta_path", [_NoOpen3d(), *sys.meta_path])
    out = tmp_path / "s.mcap"
    result = run("export", office.map, "--time", "2026-11-23 08:30", "--format", "mcap", "-o", out)
    assert result.exit_code == 0, result.stderr
    assert len(scene_updates(out)) == 1
    assert "open3d" not in sys.modules


def test_the_series_scale_is_the_scenes_own(sample_map: Path) -> None:
    """The shared sphere scale, read from the predictor's batch path for the node rows, is
    the one the steps' scenes give (pooled node flows of a scene per step), with a
    historical step among the times too."""
    from aion_cli.formats.scene_colours import display_flow_scale
    from aion_cli.mapquery import load_map
    from aion_cli.scene import scene_at
    from aion_cli.scene_frames import series_flow_scale

    loaded = load_map(sample_map)
    start = parse_time("2026-01-12 05:00", UTC)
    times: list[int | None] = [start + k * 3_600 * 10**9 for k in range(16)]
    for steps in (times, [*times, None], [None]):
        pooled = np.concatenate([scene_at(loaded, t).node_flow for t in steps])
        assert series_flow_scale(loaded, steps) == display_flow_scale(pooled)[0]


def test_the_metadata_names_the_steps_at_hours_no_log_observed(
    office: Office, tmp_path: Path
) -> None:
    """The office log observed 08:00-08:20 UTC: of a 07:00-09:00 series, the 07:00 and 09:00
    steps are extrapolated, which the file's aion metadata lists."""
    out = tmp_path / "three.mcap"
    result = run(
        "export", office.map, "--from", "2026-11-23 07:00", "--to", "2026-11-23 09:00",
        "--step", "1h", "--tz", "UTC", "--format", "mcap", "-o", out,
    )
    assert result.exit_code == 0, result.stderr
    with out.open("rb") as fh:
        (record,) = [m for m in make_reader(fh).iter_metadata() if m.name == "aion"]
    assert record.metadata["extrapolated"] == (
        "2026-11-23 07:00:00+00:00, 2026-11-23 09:00:00+00:00"
    )
    assert record.metadata["steps"] == "3"
    # each step's flag in predict's words, as its series JSON and CSV give it
    series = run_json(
        "predict", office.map, "--from", "2026-11-23 07:00", "--to", "2026-11-23 09:00",
        "--step", "1h", "--tz", "UTC", "--format", "json",
    )
    assert series["hour_observed"] == [False, True, False]
    assert record.metadata["hour_observed"] == "false, true, false"
    past = tmp_path / "past.mcap"
    assert run("export", office.map, "--historical", "-o", past).exit_code == 0
    with past.open("rb") as fh:
        (record,) = [m for m in make_reader(fh).iter_metadata() if m.name == "aion"]
    assert record.metadata["hour_observed"] == ""  # as observed: no hour to speak of
    assert record.metadata["extrapolated"] == ""


def test_the_metadata_holds_predicts_values_in_full(
    series: Path, predicted: list[dict[str, Any]]
) -> None:
    """Each entity's ``flow``, ``entropy`` and ``direction_deg`` were written to 4 (5)
    significant digits (a flow of 0.123456 read back as 0.1235): they are the values of
    ``aion predict --format json`` at the step, to 1e-12."""
    checked = 0
    for (_, update), entries in zip(scene_updates(series), predicted, strict=True):
        for entity in update.entities:
            if not (entity.spheres or entity.cubes):
                continue
            meta = {m.key: m.value for m in entity.metadata}
            want = entries[entity.id]
            for key in ("flow", "entropy", "direction_deg"):
                if want[key] is None:
                    assert meta[key] == "null", (entity.id, key)
                    continue
                assert float(meta[key]) == pytest.approx(want[key], rel=1e-12, abs=1e-12), (
                    entity.id, key, meta[key], want[key],
                )  # fmt: skip
                checked += 1
    assert checked > 100


def test_times_a_ros_2_stamp_cannot_hold_are_refused_before_any_scene(
    office: Office, tmp_path: Path
) -> None:
    """/aion/markers and /tf_static stamp their time in ROS 2's signed 32-bit seconds, which
    end at 2038-01-19 03:14:07 UTC: a step there is logged, its stamps that second; one a
    second later (or a series that reaches it, or a time before 1970) is one line, exit 2,
    naming the time, and no file. It had been an internal error (exit 1) from struct.pack,
    after every step before it was computed."""
    last = tmp_path / "last.mcap"
    ok = run("export", office.map, "--time", "2038-01-19 03:14:07", "--tz", "UTC", "-o", last)
    assert ok.exit_code == 0, ok.stderr
    (tf,) = ros_messages(last, "/tf_static")
    assert (tf.transforms[0].header.stamp.sec, tf.transforms[0].header.stamp.nanosec) == (
        2**31 - 1, 0
    )
    assert [t for t, _ in scene_updates(last)] == [(2**31 - 1) * 10**9]
    cases = [
        (["--time", "2038-01-19 03:14:08"], "2038-01-19 03:14:08 UTC"),
        (["--from", "2038-01-18 00:00", "--to", "2038-01-20 00:00", "--step", "12h"],
         "2038-01-19 12:00:00 UTC"),
        (["--time", "1969-12-31 23:59"], "1969-12-31 23:59:00 UTC"),
        (["--time", "2260-06-01 00:00"], "2260-06-01 00:00:00 UTC"),
    ]
    for args, named in cases:
        out = tmp_path / "late.mcap"
        result = run("export", office.map, *args, "--tz", "UTC", "-o", out)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, f"cannot log a scene at {named}")
        assert "1970-01-01 .. 2038-01-19 03:14:07 UTC" in result.stderr
        assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["last.mcap"]
