"""Bad logs, one fault per test: what ``aion build`` does with each.

Every log is generated in ``tmp_path`` with ``formats.writers.LogWriter`` (and spark_dsg for the
scene graphs), with the fault placed at a known message or byte, so each test states exactly
what aion must keep, drop (and count), or refuse with a one-line error.
"""

from __future__ import annotations

import random
import struct
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.robustness.conftest import (
    T0,
    Message,
    S,
    assert_one_error,
    assert_same_arrays,
    build_json,
    graph_payload,
    map_arrays,
    person,
    robot_tf,
    run,
    scene_graph,
    walk,
    write_log,
)


def spread(n: int, start_s: int = 0) -> list[Message]:
    """``n`` person messages one second apart, walking over 40 cells (several MCAP chunks)."""
    return [
        person(T0 + (start_s + k) * S, (0.5 * (k % 40), 1.0, 0.0), track=k % 5) for k in range(n)
    ]


def chunk_indexes(path: Path) -> list[Any]:
    """The MCAP's chunk indexes in file order."""
    from mcap.reader import make_reader

    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    return sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)


N_SPREAD = 5000


@pytest.fixture(scope="module")
def spread_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An MCAP of ``spread(N_SPREAD)`` (five chunks or more), written once."""
    return write_log(tmp_path_factory.mktemp("spread") / "full.mcap", spread(N_SPREAD))


def fails(result: Any, *fragments: str) -> None:
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, *fragments)


# -- containers: truncation, corruption, empty, no usable topic ------------------------------


def test_truncated_mcap_builds_from_the_readable_part_and_says_where_it_stopped(
    spread_log: Path, tmp_path: Path
) -> None:
    data = spread_log.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 6 // 10])
    report = build_json(cut, "-o", tmp_path / "cut.aion")
    read = report["detections"]["read"]
    assert 1000 < read < N_SPREAD
    note = next(n for n in report["notes"] if "truncated or corrupt MCAP" in n)
    stopped = int(note.split("read stopped at byte ")[1].split()[0])
    assert 0 < stopped <= len(data) * 6 // 10
    assert f"after {read} messages" in note
    assert map_arrays(tmp_path / "cut.aion")  # a complete, checksummed map
    assert report["time_span"]["end_ns"] == T0 + (read - 1) * S  # exactly the first `read` s


@pytest.mark.parametrize("seed", range(4))
def test_corrupt_mcap_chunk_is_skipped_alone_and_named(
    seed: int, spread_log: Path, tmp_path: Path
) -> None:
    """A flipped bit in a chunk's compressed bytes: often still valid zstd, but garbage; the
    chunk CRC catches it. That chunk alone is skipped with a note naming it and its messages
    (issue 14: the chunks after it used to be ignored too)."""
    full = spread_log
    chunks = chunk_indexes(full)
    assert len(chunks) >= 4
    rng = random.Random(seed)
    victim = chunks[2]
    end = victim.chunk_start_offset + victim.chunk_length
    data = bytearray(full.read_bytes())
    data[rng.randrange(end - victim.compressed_size, end)] ^= 1 << rng.randrange(8)
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    report = build_json(bad, "-o", tmp_path / "bad.aion")
    inside = sum(
        1
        for k in range(N_SPREAD)
        if victim.message_start_time <= T0 + k * S <= victim.message_end_time
    )
    assert report["detections"]["read"] == N_SPREAD - inside
    assert any(
        f"corrupt chunk at byte {victim.chunk_start_offset} skipped" in n
        and f"{inside:,} messages lost (/tracks {inside:,})" in n
        for n in report["notes"] + report.get("warnings", [])
    ), report


def test_corrupt_chunk_in_an_mcap_without_summary_is_skipped_by_the_linear_read(
    spread_log: Path, tmp_path: Path
) -> None:
    full = spread_log
    chunks = chunk_indexes(full)
    victim = chunks[2]
    data = bytearray(full.read_bytes()[: chunks[-1].chunk_start_offset])  # no summary
    data[victim.chunk_start_offset + victim.chunk_length - 10] ^= 0x10
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    report = build_json(bad, "-o", tmp_path / "bad.aion")
    inside = sum(
        1
        for k in range(N_SPREAD)
        if victim.message_start_time <= T0 + k * S <= victim.message_end_time
    )
    before_last = sum(1 for k in range(N_SPREAD) if T0 + k * S < chunks[-1].message_start_time)
    assert report["detections"]["read"] == before_last - inside  # the chunks after it too
    assert any(
        f"corrupt chunk at byte {victim.chunk_start_offset} skipped" in n
        for n in report["notes"] + report.get("warnings", [])
    ), report


def test_truncated_bag_is_a_clear_error_and_writes_no_map(tmp_path: Path) -> None:
    bag = write_log(tmp_path / "full.bag", spread(500), "bag")
    data = bag.read_bytes()
    cut = tmp_path / "cut.bag"
    cut.write_bytes(data[: len(data) // 2])
    fails(run("build", cut, "-o", tmp_path / "cut.aion"), "not a readable ROS 1 bag")
    assert not (tmp_path / "cut.aion").exists()


@pytest.mark.parametrize(
    ("index_pos", "fragment"), [("middle", "index looks damaged"), ("zero", "not indexed")]
)
def test_bag_with_a_broken_index_is_a_clear_error(
    index_pos: str, fragment: str, tmp_path: Path
) -> None:
    bag = write_log(tmp_path / "full.bag", spread(200), "bag")
    data = bytearray(bag.read_bytes())
    at = data.index(b"index_pos=") + len(b"index_pos=")
    data[at : at + 8] = struct.pack("<Q", len(data) // 2 + 3 if index_pos == "middle" else 0)
    broken = tmp_path / "broken.bag"
    broken.write_bytes(bytes(data))
    result = run("build", broken, "-o", tmp_path / "b.aion")
    fails(result, fragment)
    assert "rosbag reindex" in result.stderr  # the hint says what to do


@pytest.mark.parametrize("container", ["mcap", "bag"])
def test_log_without_messages_is_a_clear_error(container: str, tmp_path: Path) -> None:
    empty = write_log(tmp_path / f"empty.{container}", [], container)
    fails(run("build", empty, "-o", tmp_path / "e.aion"), "no messages")


def test_empty_log_among_good_ones_is_a_note(tmp_path: Path) -> None:
    good = write_log(tmp_path / "good.mcap", walk(30))
    empty = write_log(tmp_path / "empty.mcap", [])
    report = build_json(good, empty, "-o", tmp_path / "m.aion")
    assert report["detections"]["read"] == 30
    assert any("empty.mcap: no messages" in n for n in report["notes"])


def test_log_with_no_usable_topic_is_an_error_naming_the_way_out(tmp_path: Path) -> None:
    chatter = [("/chatter", "std_msgs/msg/String", {"data": "hi"}, T0 + k * S) for k in range(5)]
    log = write_log(tmp_path / "chatter.mcap", [*chatter, robot_tf(T0)])
    result = run("build", log, "-o", tmp_path / "c.aion")
    fails(result, "no people-detection topic")
    hint = result.stderr.splitlines()[1]
    assert "/chatter (std_msgs/msg/String)" in hint  # what the log has instead
    assert "/tf (tf2_msgs/msg/TFMessage)" in hint
    assert "aion info" in hint
    # naming a topic that is not a detection topic: the error lists the candidates
    log2 = write_log(tmp_path / "both.mcap", [*chatter, *walk(5)])
    result = run("build", log2, "--detections-topic", "/chatter", "-o", tmp_path / "c.aion")
    fails(result, "/chatter", "std_msgs/msg/String")
    assert "--detections-topic /tracks" in result.stderr


# -- several inputs, order, stamps -----------------------------------------------------------


def office_messages(seconds: int) -> list[Message]:
    """TF every 5 s, a scene graph every 60 s, a person near p1 every 2 s."""
    payload = graph_payload()
    out: list[Message] = []
    for k in range(seconds):
        t = T0 + k * S
        if k % 60 == 0:
            out.append(scene_graph(t, payload))
        if k % 5 == 0:
            out.append(robot_tf(t))
        if k % 2 == 1:
            out.append(person(t, (2.1 + 0.01 * (k % 7), 0.1, 0.0), track=1 + k % 3))
    return out


def test_mixed_ros1_and_ros2_inputs_equal_one_log(tmp_path: Path) -> None:
    """A ROS 1 bag, a ROS 2 MCAP and a ROS 1-profile MCAP in one build give the same map as
    the same messages in one ROS 2 MCAP."""
    msgs = office_messages(1800)
    third = len(msgs) // 3
    parts = [
        write_log(tmp_path / "a.bag", msgs[:third], "bag"),
        write_log(tmp_path / "b.mcap", msgs[third : 2 * third], "mcap"),
        write_log(tmp_path / "c.mcap", msgs[2 * third :], "mcap-ros1"),
    ]
    mixed = build_json(*parts, "-o", tmp_path / "mixed.aion")
    single = build_json(write_log(tmp_path / "all.mcap", msgs), "-o", tmp_path / "all.aion")
    assert mixed["detections"] == single["detections"]
    assert mixed["detections"]["read"] == 900
    assert mixed["graph"]["messages"] == single["graph"]["messages"] == 30
    assert_same_arrays(map_arrays(tmp_path / "mixed.aion"), map_arrays(tmp_path / "all.aion"))


def test_out_of_order_log_times_are_read_in_time_order(tmp_path: Path) -> None:
    msgs = office_messages(1200)
    shuffled = msgs[:]
    random.Random(7).shuffle(shuffled)
    build_json(write_log(tmp_path / "shuffled.mcap", shuffled), "-o", tmp_path / "s.aion")
    build_json(write_log(tmp_path / "sorted.mcap", msgs), "-o", tmp_path / "o.aion")
    assert_same_arrays(map_arrays(tmp_path / "s.aion"), map_arrays(tmp_path / "o.aion"))


def test_duplicate_messages_are_counted_as_detections(tmp_path: Path) -> None:
    """aion does not deduplicate: a message recorded twice is two detections (same window,
    same cell), and nothing breaks."""
    msgs = walk(100)
    twice = sorted([*msgs, *msgs[10:20]], key=lambda m: m[3])
    report = build_json(write_log(tmp_path / "dup.mcap", twice), "-o", tmp_path / "d.aion")
    assert report["detections"] == {"read": 110, "used": 110, "dropped": {}}


def test_zero_header_stamps_fall_back_to_log_time(tmp_path: Path) -> None:
    """Stamps of 0 (an unset header): the log time is used (and counted in a note), so the map
    equals the map of the same log with proper stamps."""
    stamped = [person(T0 + k * S, (2.1, 0.1, 0.0)) for k in range(1300)]
    zero = [person(T0 + k * S, (2.1, 0.1, 0.0), header_ns=0) for k in range(1300)]
    a = build_json(write_log(tmp_path / "zero.mcap", zero), "-o", tmp_path / "z.aion")
    b = build_json(write_log(tmp_path / "ok.mcap", stamped), "-o", tmp_path / "k.aion")
    assert a["detections"] == b["detections"] == {"read": 1300, "used": 1300, "dropped": {}}
    assert a["windows"] == b["windows"] == 2
    assert "1,300 detections had a zero header stamp" in " ".join(a["notes"])
    assert "zero header stamp" not in " ".join(b["notes"])
    assert_same_arrays(map_arrays(tmp_path / "z.aion"), map_arrays(tmp_path / "k.aion"))


@pytest.mark.parametrize("jump_s", [3 * 86400, (2**31 - 1) - T0 // S])  # 3 days; to 2038
def test_clock_jump_is_survived_with_bounded_memory(jump_s: int, tmp_path: Path) -> None:
    """One detection stamped days (or years) ahead of the log: the build finishes, every
    detection is used or counted, memory stays small (no dense allocation over the gap).

    Known weakness (docs/ROBUSTNESS.md): the bad stamp opens a far-future window, so later
    detections in other chunks are dropped as ``before_window`` (counted, not lost silently).
    """
    before = walk(300)
    jumped = person(T0 + 300 * S, (2.1, 0.1, 0.0), header_ns=T0 + jump_s * S)
    after = walk(300, start_s=301)
    log = write_log(tmp_path / "jump.mcap", [*before, jumped, *after])
    tracemalloc.start()
    try:
        report = build_json(log, "-o", tmp_path / "j.aion", "--batch-size", "50")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    det = report["detections"]
    assert det["read"] == 601
    assert det["used"] + sum(det["dropped"].values()) == 601
    assert det["used"] >= 301  # everything up to the jump, at least
    assert peak < 200 * 2**20, peak
    assert (tmp_path / "j.aion").stat().st_size < 2 * 2**20
    # the log's time span comes from log times, not from the bad stamp
    assert report["time_span"]["end_ns"] == T0 + 600 * S


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


def payload_1_1_2() -> bytes:
    """Five places as spark_dsg 1.1.2 wrote them: 1.1.3 added a bool (``anti_frontier``) after
    ``num_frontier_voxels``; unique voxel counts mark where to drop it (as in
    tests/formats/test_dsg.py)."""
    import spark_dsg

    G = spark_dsg.DynamicSceneGraph()
    for i in range(5):
        attrs = spark_dsg.PlaceNodeAttributes()
        attrs.position = np.array([2.0 * i, 0.0, 0.0])
        attrs.real_place = True
        attrs.num_frontier_voxels = 0x0BADF000 + i
        attrs.anti_frontier = True
        G.add_node(spark_dsg.DsgLayers.PLACES, spark_dsg.NodeSymbol("p", i), attrs)
    data = G.to_binary()
    for i in range(5):
        marker = b"\xcf" + (0x0BADF000 + i).to_bytes(8, "little")
        j = data.index(marker) + len(marker)
        assert data[j] == 0xC3  # anti_frontier = True
        data = data[:j] + data[j + 1 :]
    return data


def test_older_scene_graph_version_keeps_stdout_clean(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """Payloads of an older spark_dsg (decoded through the versioned-header fallback, one load
    per message): spark_dsg's C++ logger warns on stdout for every load, which corrupted
    ``--format json``; nothing may reach the file descriptors, and the report names the
    version used."""
    old = payload_1_1_2()
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
