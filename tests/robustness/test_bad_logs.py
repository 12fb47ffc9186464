"""Bad log messages, one fault per test: what ``aion build`` does with non-finite or absurd
coordinates, unknown frames or missing TF, garbage, older or damaged scene graphs, damaged
detection payloads, and detections before (or without) any scene graph. Bad containers:
``test_bad_log_files.py``; inputs, order and stamps: ``test_bad_log_streams.py``.

Every log is generated in ``tmp_path`` with ``formats.writers.LogWriter`` (and spark_dsg for the
scene graphs), with the fault placed at a known message or byte, so each test states exactly
what aion must keep, drop (and count), or refuse with a one-line error.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.formats.dsg_builders import five_places_payload_1_1_2
from tests.robustness.conftest import (
    T0,
    S,
    build_json,
    fails,
    graph_payload,
    map_arrays,
    person,
    robot_tf,
    run,
    scene_graph,
    walk,
    write_log,
)

# -- coordinates and frames ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("xyz", "reason"),
    [
        ((float("nan"), 0.0, 0.0), "nan"),
        ((0.0, float("inf"), 0.0), "nan"),
        ((0.0, 0.0, float("-inf")), "nan"),
        ((1e12, 0.0, 0.0), "out_of_range"),
        ((0.0, -1e12, 0.0), "out_of_range"),
        ((1e300, 1e300, 1e300), "out_of_range"),
    ],
)
def test_non_finite_and_absurd_coordinates_are_dropped_and_counted(
    xyz: tuple[float, float, float], reason: str, tmp_path: Path
) -> None:
    msgs = [*walk(50), person(T0 + 50 * S, xyz), *walk(50, start_s=51)]
    report = build_json(write_log(tmp_path / "bad.mcap", msgs), "-o", tmp_path / "b.aion")
    assert report["detections"] == {"read": 101, "used": 100, "dropped": {reason: 1}}
    arrays = map_arrays(tmp_path / "b.aion")
    for name, arr in arrays.items():
        if arr.dtype.kind == "f" and "xyz" in name:
            assert np.isfinite(arr).all(), name
            assert arr.size == 0 or np.abs(arr).max() < 1e6, name


def test_unknown_frame_with_tf_is_a_transform_error_naming_known_frames(tmp_path: Path) -> None:
    tf = [robot_tf(T0 + k * S) for k in range(100)]
    msgs = sorted(
        [*tf, *walk(50), person(T0 + 60 * S + 1, (1, 2, 0), frame="camera")], key=lambda m: m[3]
    )
    result = run("build", write_log(tmp_path / "f.mcap", msgs), "-o", tmp_path / "f.aion")
    fails(result, "unknown frame 'camera'", "base_link")
    assert not (tmp_path / "f.aion").exists()


def test_frame_without_any_tf_is_an_error_suggesting_map_frame(tmp_path: Path) -> None:
    msgs = [person(T0 + k * S, (1, 2, 0), frame="odom") for k in range(20)]
    log = write_log(tmp_path / "odom.mcap", msgs)
    result = run("build", log, "-o", tmp_path / "o.aion")
    fails(result, "'odom'")
    assert "--map-frame odom" in result.stderr
    assert (
        build_json(log, "--map-frame", "odom", "-o", tmp_path / "o.aion")["detections"]["used"]
        == 20
    )
    # info says it before the build fails: it reads the frames of the first messages
    info = run("info", log, "--format", "json")
    assert json.loads(info.stdout)["frames_without_tf"] == {"/tracks": ["odom"]}
    table = " ".join(run("info", log).stderr.split())
    assert "/tracks holds detections in frame 'odom', and the log has no TF to 'map'" in table
    assert "build with --map-frame odom" in table
    in_map = write_log(tmp_path / "map.mcap", [person(T0 + k * S, (1, 2, 0)) for k in range(5)])
    assert json.loads(run("info", in_map, "--format", "json").stdout)["frames_without_tf"] == {}


def test_info_names_detection_frames_the_tf_does_not_connect_to_map(tmp_path: Path) -> None:
    """With TF: detections in 'laser', the TF joining map -> base_link only: info names
    'laser' (and the --map-frame that builds the log); once the TF joins laser too, nothing."""
    people = [person(T0 + k * S, (1, 2, 0), frame="laser") for k in range(10)]
    apart = write_log(tmp_path / "apart.mcap", people + [robot_tf(T0 + k * S) for k in range(10)])
    doc = json.loads(run("info", apart, "--format", "json").stdout)
    assert doc["frames_without_tf"] == {"/tracks": ["laser"]}
    table = " ".join(run("info", apart).stderr.split())
    assert "holds detections in frame 'laser', which the log's TF (its first 500 messages" in table
    assert "build with --map-frame laser" in table
    fails(run("build", apart, "-o", tmp_path / "a.aion"), "laser")  # what info foresaw
    joined = write_log(
        tmp_path / "joined.mcap",
        people + [robot_tf(T0 + k * S) for k in range(10)]
        + [robot_tf(T0 + k * S, child="laser") for k in range(10)],
    )
    assert json.loads(run("info", joined, "--format", "json").stdout)["frames_without_tf"] == {}


def test_known_frame_outside_the_tf_time_range_is_counted(tmp_path: Path) -> None:
    tf = [robot_tf(T0 + k * S) for k in range(30)]
    msgs = [person(T0 + k * S, (1, 0, 0), frame="base_link") for k in range(100)]
    log = write_log(tmp_path / "tf.mcap", sorted([*tf, *msgs], key=lambda m: m[3]))
    report = build_json(log, "-o", tmp_path / "t.aion")
    assert report["detections"]["dropped"] == {"no_transform": 70}
    assert report["detections"]["used"] == 30


# -- scene graphs ----------------------------------------------------------------------------


def native_output(capfd: pytest.CaptureFixture[str]) -> str:
    """What C/C++ code (spark_dsg's logger) wrote to file descriptors 1 and 2 so far: click's
    runner only swaps Python's ``sys.stdout``, so in-process runs still expose it here."""
    import ctypes

    ctypes.CDLL(None).fflush(None)  # C stdio buffers a pipe or file until exit
    captured = capfd.readouterr()
    return captured.out + captured.err


def test_garbage_scene_graph_payload_is_a_clear_error_and_no_map(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """A DsgUpdate whose payload no spark_dsg version reads: the build stops with one error
    line naming the payload, spark_dsg's own warnings for each version tried do not leak onto
    stdout or stderr, and the output already there (an empty file, which aion may replace) is
    left as it was."""
    msgs = [*walk(40), scene_graph(T0 + 40 * S, b"\x01\x02garbage" * 50), *walk(40, 41)]
    log = write_log(tmp_path / "g.mcap", msgs)
    out = tmp_path / "g.aion"
    out.write_bytes(b"")
    native_output(capfd)
    result = run("build", log, "-o", out)
    fails(result, "cannot decode scene-graph payload (450 bytes)")
    assert result.stdout == ""
    assert native_output(capfd) == ""
    assert out.read_bytes() == b""


def test_older_scene_graph_version_keeps_stdout_clean(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """Payloads of an older spark_dsg (decoded through the versioned-header fallback, one load
    per message): spark_dsg's C++ logger warns on stdout for every load, which corrupted
    ``--format json``; nothing may reach the file descriptors, and the report names the
    version used."""
    old = five_places_payload_1_1_2()
    msgs = [scene_graph(T0 + k * 60 * S, old) for k in range(5)]
    log = write_log(tmp_path / "old.mcap", sorted([*msgs, *walk(300, 1)], key=lambda m: m[3]))
    native_output(capfd)
    report = build_json(log, "-o", tmp_path / "old.aion")
    assert native_output(capfd) == ""
    assert report["graph"]["dsg_version"] == "1.1.2"
    assert report["graph"]["messages"] == 5
    assert report["nodes"] == 5


def test_damaged_scene_graph_after_a_good_one_is_skipped_and_counted(tmp_path: Path) -> None:
    """A truncated DsgUpdate between good ones: the build keeps the graph it has, skips the
    damaged message, counts it and says so; every detection is still used."""
    payload = graph_payload()
    msgs = [
        scene_graph(T0, payload),
        *walk(40, 1),
        scene_graph(T0 + 41 * S, payload[: len(payload) // 2]),
        *walk(40, 42),
        scene_graph(T0 + 90 * S, payload),
    ]
    report = build_json(write_log(tmp_path / "t.mcap", msgs), "-o", tmp_path / "t.aion")
    assert report["graph"]["messages"] == 2
    assert report["graph"]["skipped"] == 1
    assert report["detections"]["used"] == 80
    assert any("damaged scene-graph message(s) skipped" in n for n in report["notes"])


def test_damaged_scene_graph_with_a_pinned_version_is_a_clear_error(tmp_path: Path) -> None:
    """With --dsg-version the user said how to read the graphs: a failure stops the build."""
    payload = graph_payload()
    msgs = [scene_graph(T0, payload), *walk(40, 1),
            scene_graph(T0 + 41 * S, payload[: len(payload) // 2])]
    log = write_log(tmp_path / "p.mcap", msgs)
    result = run("build", log, "-o", tmp_path / "p.aion", "--dsg-version", "1.1.3")
    fails(result, "cannot decode scene-graph payload")
    assert not (tmp_path / "p.aion").exists()


def test_a_dsg_version_aion_does_not_read_is_refused_before_the_build(tmp_path: Path) -> None:
    """--dsg-version 9.9.9 (a typo, or a spark_dsg newer than the installed one) built the map,
    exit 0, reading every payload as the installed version and recording 9.9.9 as the graphs'
    version; it is refused before anything is read, naming the versions aion reads. A pinned
    version that fails on a payload no longer hints to pin a version with --dsg-version."""
    from aion_cli.formats.dsg import FALLBACK_VERSIONS, installed_version

    log = write_log(tmp_path / "g.mcap", [scene_graph(T0, graph_payload()), *walk(40, 1)])
    result = run("build", log, "--dsg-version", "9.9.9", "-o", tmp_path / "x.aion")
    fails(result, "--dsg-version 9.9.9: aion reads scene-graph payloads")
    said = " ".join(result.stderr.split())
    assert f"of spark_dsg {installed_version()}, " in said, said
    assert all(v in said for v in FALLBACK_VERSIONS), said
    assert "hint: leave out --dsg-version" in said, said
    assert not (tmp_path / "x.aion").exists()
    older = next(v for v in FALLBACK_VERSIONS if v != installed_version())
    result = run("build", log, "--dsg-version", older, "-o", tmp_path / "y.aion")
    fails(result, "cannot decode scene-graph payload")  # the payload is the installed version
    said = " ".join(result.stderr.split())
    assert f"hint: --dsg-version {older} does not read it: leave the option out" in said, said


def test_damaged_detection_message_is_skipped_and_counted(tmp_path: Path) -> None:
    """One TrackedPersons payload cut short among good ones: dropped as an undecodable
    message, the others are used."""
    from aion_cli.formats.writers import LogWriter

    path = tmp_path / "d.mcap"
    good = walk(30)
    with LogWriter(path, "mcap") as writer:
        for k, (topic, msgtype, msg, t_ns) in enumerate(good):
            data = writer.serialize(msgtype, msg)
            writer.write_raw(topic, msgtype, data[: len(data) // 2] if k == 10 else data, t_ns)
    report = build_json(path, "-o", tmp_path / "d.aion")
    assert report["detections"]["dropped"]["undecodable_messages"] == 1
    assert report["detections"]["used"] == 29


def test_scene_graph_with_a_damaged_node_name_is_a_clear_error(tmp_path: Path) -> None:
    """spark_dsg decodes a payload whose room name is not UTF-8 and fails only when the name
    is read (a UnicodeDecodeError, which ended as an internal error; found by fuzzing)."""
    payload = bytes(graph_payload())
    assert payload.count(b"room1") == 1
    damaged = payload.replace(b"room1", b"ro\xb0m1")
    msgs = [*walk(20), scene_graph(T0 + 20 * S, damaged), *walk(20, 21)]
    result = run("build", write_log(tmp_path / "n.mcap", msgs), "-o", tmp_path / "n.aion")
    fails(result, "not UTF-8")
    assert not (tmp_path / "n.aion").exists()


def test_detections_before_the_first_scene_graph_bind_to_its_nodes(tmp_path: Path) -> None:
    """15 minutes of people near p1 with no graph yet: they are kept on hash cells, and once
    the graph arrives the cells bind to the node; nothing is lost."""
    from aion_cli.mapquery import load_map

    early = walk(900)
    graph = scene_graph(T0 + 900 * S + 1, graph_payload())
    late = walk(900, start_s=901)
    log = write_log(tmp_path / "late.mcap", [*early, graph, *late])
    report = build_json(log, "-o", tmp_path / "l.aion")
    assert report["detections"] == {"read": 1800, "used": 1800, "dropped": {}}
    assert report["cells"] == 0  # no unbound cell left
    assert report["bound_cells"] >= 1
    assert report["nodes_with_flow"] == 1
    loaded = load_map(tmp_path / "l.aion")
    entries = loaded.state.entries
    assert len(entries.node_rows()) == 1
    assert entries.total_count() == pytest.approx(1800)


def test_log_without_any_scene_graph_keeps_flows_on_hash_cells(tmp_path: Path) -> None:
    """Only detections, no scene graph anywhere: flows stay on hash cells, with a note."""
    report = build_json(write_log(tmp_path / "only.mcap", walk(100)), "-o", tmp_path / "o.aion")
    assert report["cells"] == 1
    assert report["graph"]["source"] == "none"
    assert any("no scene graph" in n for n in report["notes"])
