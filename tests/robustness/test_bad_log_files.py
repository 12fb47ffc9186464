"""Bad log files, one fault per test: what ``aion build`` does with a truncated or corrupted
MCAP or bag, an empty log, a log without a usable topic. Several inputs of mixed ROS versions,
out-of-order log times, duplicates, zero header stamps and a clock jump:
``test_bad_log_streams.py``; bad coordinates, frames, scene graphs and damaged messages:
``test_bad_logs.py``.

Every log is generated in ``tmp_path`` with ``formats.writers.LogWriter`` (and spark_dsg for the
scene graphs), with the fault placed at a known message or byte, so each test states exactly
what aion must keep, drop (and count), or refuse with a one-line error.
"""

from __future__ import annotations

import json
import random
import struct
from pathlib import Path
from typing import Any

import pytest

from tests.robustness.conftest import (
    T0,
    TRACKED,
    Message,
    S,
    build_json,
    fails,
    map_arrays,
    person,
    robot_tf,
    run,
    stamp,
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
    # lost data is a warning (not a note): it stays with -q, and JSON lists it as one
    warning = next(n for n in report["warnings"] if "truncated or corrupt MCAP" in n)
    stopped = int(warning.split("read stopped at byte ")[1].split()[0])
    assert 0 < stopped <= len(data) * 6 // 10
    assert f"after {read:,} messages" in warning
    assert map_arrays(tmp_path / "cut.aion")  # a complete, checksummed map
    assert report["time_span"]["end_ns"] == T0 + (read - 1) * S  # exactly the first `read` s
    quiet = run("build", cut, "-o", tmp_path / "quiet.aion", "-q")
    assert quiet.exit_code == 0
    assert f"warning: {warning}" in " ".join(quiet.stderr.split())


def test_an_mcap_cut_between_two_chunks_is_read_with_a_warning(
    spread_log: Path, tmp_path: Path
) -> None:
    """A recorder killed between two chunk writes leaves an MCAP that ends between two
    records, without DataEnd, summary and footer. Its chunks were read, but not a word said
    that the file was cut short (a file cut inside a record was a warning): the build's map,
    ``info`` and the JSON report looked complete. Now the same warning kind names it."""
    chunks = chunk_indexes(spread_log)
    cut_at = chunks[3].chunk_start_offset
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(spread_log.read_bytes()[:cut_at])
    before = sum(1 for k in range(N_SPREAD) if T0 + k * S < chunks[3].message_start_time)
    report = build_json(cut, "-o", tmp_path / "cut.aion")
    assert report["detections"]["read"] == before  # the whole chunks before the cut
    warning = next(w for w in report["warnings"] if "truncated MCAP" in w)
    assert f"ends at byte {cut_at} after {before:,} messages" in warning
    info = run("info", cut, "--format", "json")
    assert warning in json.loads(info.stdout)["warnings"]
    whole = build_json(spread_log, "-o", tmp_path / "whole.aion")
    assert not [w for w in whole["warnings"] if "truncated" in w]  # a closed file: none


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_log_cut_short_before_its_people_is_an_error_naming_the_cut(
    workers: str, tmp_path: Path
) -> None:
    """A tracker that published empty messages for an hour, then people; the file cut
    before the first person. The build fails (no map from nobody), but the error said only
    "no people detection in the N messages" and hinted at vision_msgs' class filter: the
    truncation warning, printed with a map, was lost with the error. The error now names it."""
    from aion_cli.formats.writers import LogWriter

    n_empty = 3600
    nobody = [{"header": {"stamp": stamp(T0 + k * S), "frame_id": "map"}, "tracks": []}
              for k in range(n_empty)]
    empty = [("/tracks", TRACKED, msg, T0 + k * S) for k, msg in enumerate(nobody)]
    full = tmp_path / "full.mcap"
    with LogWriter(full, "mcap", chunk_size=16384) as writer:  # several chunks of nobody
        for topic, msgtype, msg, t_ns in empty + spread(600, start_s=n_empty):
            writer.write(topic, msgtype, msg, t_ns)
    first_person = T0 + n_empty * S
    cut_at = next(
        c.chunk_start_offset for c in chunk_indexes(full) if c.message_end_time >= first_person
    )
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(full.read_bytes()[: cut_at + 100])  # inside the first chunk with people
    result = run("build", cut, "-o", tmp_path / "cut.aion", "--workers", workers)
    fails(result, "no people detection in the", "truncated or corrupt MCAP: read stopped at byte")
    hint = result.stderr.splitlines()[1]
    assert "cut short or damaged, the people may be in what was not read" in hint
    assert not (tmp_path / "cut.aion").exists()
    whole = run("build", write_log(tmp_path / "empty.mcap", empty), "-o", tmp_path / "e.aion")
    fails(whole, f"no people detection in the {n_empty:,} messages of /tracks")  # nothing cut:
    assert "read with warnings" not in whole.stderr  # no word of warnings
    assert "may be in what was not read" not in whole.stderr


def _messages_in(chunk: Any) -> int:
    """How many of the spread log's messages (one a second from ``T0``) ``chunk`` holds."""
    return sum(
        1
        for k in range(N_SPREAD)
        if chunk.message_start_time <= T0 + k * S <= chunk.message_end_time
    )


def test_info_verify_names_a_corrupt_mcap_chunk_and_its_lost_messages(
    spread_log: Path, tmp_path: Path
) -> None:
    """A flipped bit in the third chunk: ``aion info`` listed the log's 5,000 messages without a
    word (it reads the summary), and ``--verify`` was refused for logs. ``info --verify`` now
    reads every message as a build does: the chunk is named with the messages it loses, as the
    build names it, and ``verified.messages_read`` counts the others."""
    chunks = chunk_indexes(spread_log)
    victim = chunks[2]
    end = victim.chunk_start_offset + victim.chunk_length
    data = bytearray(spread_log.read_bytes())
    data[end - victim.compressed_size // 2] ^= 0x10
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    inside = _messages_in(victim)
    named = (f"corrupt chunk at byte {victim.chunk_start_offset} skipped",
             f"{inside:,} messages lost (/tracks {inside:,})")
    result = run("info", bad, "--verify", "--format", "json")
    assert result.exit_code == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["verified"] == {"messages_read": N_SPREAD - inside}
    assert [w for w in report["warnings"] if all(part in w for part in named)], report
    table = " ".join(run("info", bad, "--verify").stdout.split())
    assert f"messages: {N_SPREAD:,} ({N_SPREAD - inside:,} read, {inside:,} lost" in table
    whole = json.loads(run("info", spread_log, "--verify", "--format", "json").stdout)
    assert whole["verified"] == {"messages_read": N_SPREAD}
    assert not whole["warnings"]


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
    inside = _messages_in(victim)
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
    inside = _messages_in(victim)
    before_last = sum(1 for k in range(N_SPREAD) if T0 + k * S < chunks[-1].message_start_time)
    assert report["detections"]["read"] == before_last - inside  # the chunks after it too
    assert any(
        f"corrupt chunk at byte {victim.chunk_start_offset} skipped" in n
        for n in report["notes"] + report.get("warnings", [])
    ), report


@pytest.mark.parametrize("workers", ["1", "2"])  # in sequence; in time shards
def test_a_log_whose_every_chunk_is_corrupt_is_an_error_naming_the_damage(
    workers: str, spread_log: Path, tmp_path: Path
) -> None:
    """Every chunk fails its CRC: nothing can be read. The error says the messages were lost
    and where (it said "no people detection in the 0 messages of /tracks" and hinted at the
    class filter of vision_msgs, as if the topic carried nobody)."""
    chunks = chunk_indexes(spread_log)
    data = bytearray(spread_log.read_bytes())
    for chunk in chunks:
        data[chunk.chunk_start_offset + chunk.chunk_length - 10] ^= 0x10
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    result = run("build", bad, "-o", tmp_path / "bad.aion", "--workers", workers)
    fails(
        result,
        f"{N_SPREAD:,} of the {N_SPREAD:,} messages of /tracks were lost reading the logs",
        f"corrupt chunk at byte {chunks[0].chunk_start_offset} skipped",
        f"and {len(chunks) - 1:,} more warnings like it",
    )
    assert "vision_msgs" not in result.stderr
    assert "damaged" in result.stderr.splitlines()[1]
    assert not (tmp_path / "bad.aion").exists()


def test_a_map_is_not_continued_with_a_log_whose_every_chunk_is_corrupt(
    spread_log: Path, tmp_path: Path
) -> None:
    """``build --map`` took a log with every chunk corrupt as one in which nobody was seen
    ("only observed-empty windows were added to the map", exit 0), recording it in the map;
    now it is the damage error and the map is left byte for byte as it was."""
    first = write_log(tmp_path / "before.mcap", walk(30, start_s=-7200))
    built = run("build", first, "-o", tmp_path / "m.aion")
    assert built.exit_code == 0, built.stderr
    before = (tmp_path / "m.aion").read_bytes()
    data = bytearray(spread_log.read_bytes())
    for chunk in chunk_indexes(spread_log):
        data[chunk.chunk_start_offset + chunk.chunk_length - 10] ^= 0x10
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    result = run("build", bad, "--map", tmp_path / "m.aion")
    fails(result, f"{N_SPREAD:,} of the {N_SPREAD:,} messages of /tracks were lost")
    assert "the map was left as it was" in result.stderr
    assert (tmp_path / "m.aion").read_bytes() == before


@pytest.mark.parametrize("container", ["mcap", "bag", "mcap without summary"])
def test_a_log_appended_to_another_in_one_file_is_named_not_dropped_silently(
    container: str, tmp_path: Path
) -> None:
    """``cat a.mcap b.mcap > ab.mcap``: aion reads the first log, whose end its footer (or
    index) gives, and used to say nothing of the second (its 40 people were lost without a
    word). It now warns where the first ends and that another log follows; garbage after a
    log is named as such (after an MCAP without its summary too); a log alone gets no such
    warning."""
    suffix = "bag" if container == "bag" else "mcap"
    first = write_log(tmp_path / f"a.{suffix}", walk(30), suffix)
    second = write_log(tmp_path / f"b.{suffix}", walk(40, start_s=100), suffix)
    head = first.read_bytes()
    if container == "mcap without summary":  # the first cut after its data (DataEnd)
        (summary_start,) = struct.unpack_from("<Q", head, len(head) - 8 - 20)  # its footer's
        head = head[:summary_start]
    kind = "a ROS 1 bag" if container == "bag" else "an MCAP file"
    # garbage: after an MCAP without its summary it is no record a log ends with (it used
    # to be taken for a summary cut short, without a word)
    tails = [(second.read_bytes(), f"another log ({kind}"), (b"\x07" * 999, "not part")]
    if container == "mcap without summary":
        tails += [(b"\x00" * 64, "not part"), (b"copied twice\n", "not part")]
    for tail, says in tails:
        joined = tmp_path / f"joined.{suffix}"
        joined.write_bytes(head + tail)
        size = len(head) + len(tail)
        report = build_json(joined, "-o", tmp_path / "j.aion")
        assert report["detections"]["read"] == 30
        (warning,) = [w for w in report["warnings"] if "the log ends" in w]
        assert warning.startswith(
            f"joined.{suffix}: the log ends at byte {len(head):,} of {size:,}; "
            f"the {len(tail):,} bytes after it are not read: "
        )
        assert says in warning
    assert not [w for w in build_json(first, "-o", tmp_path / "a.aion")["warnings"]
                if "the log ends" in w]


@pytest.mark.parametrize("container", ["mcap", "bag"])
def test_log_without_messages_is_a_clear_error(container: str, tmp_path: Path) -> None:
    """An empty recording: nothing to build from (exit 2, no map), but ``info`` describes it
    (0 messages, a warning), as it is a well-formed file."""
    empty = write_log(tmp_path / f"empty.{container}", [], container)
    fails(run("build", empty, "-o", tmp_path / "e.aion"), "no messages")
    assert not (tmp_path / "e.aion").exists()
    info = run("info", empty)
    assert info.exit_code == 0, info.stderr
    assert "duration: none (no messages) messages: 0" in " ".join(info.stdout.split())
    assert "warning:" in info.stderr
    assert "no messages" in info.stderr
    doc = json.loads(run("info", empty, "--format", "json").stdout)
    assert doc["messages"] == 0
    assert any("no messages" in w for w in doc["warnings"])


def test_empty_log_among_good_ones_is_a_warning(tmp_path: Path) -> None:
    good = write_log(tmp_path / "good.mcap", walk(30))
    empty = write_log(tmp_path / "empty.mcap", [])
    report = build_json(good, empty, "-o", tmp_path / "m.aion")
    assert report["detections"]["read"] == 30
    assert any("empty.mcap: no messages" in n for n in report["warnings"])


def test_logs_holding_the_same_topic_at_the_same_time_are_a_warning(tmp_path: Path) -> None:
    """One recording given twice under two names (an excerpt beside the whole, as Lincoln's
    2017-05-24_25 and 2017-05-25 files are) counts its people twice: the build says so. Logs
    one after the other, or overlapping for less than a window, do not warn."""
    whole = write_log(tmp_path / "whole.mcap", walk(1800))  # 30 min
    excerpt = write_log(tmp_path / "excerpt.mcap", walk(900, start_s=600))  # its minutes 10-25
    later = write_log(tmp_path / "later.mcap", walk(700, start_s=1900))
    brush = write_log(tmp_path / "brush.mcap", walk(300, start_s=1700))  # 100 s of overlap
    report = build_json(whole, excerpt, "-o", tmp_path / "twice.aion", "--workers", "1")
    (warning,) = [w for w in report["warnings"] if "count twice" in w]
    assert warning.startswith("whole.mcap and excerpt.mcap both hold /tracks from ")
    assert "(14m59s)" in warning  # the excerpt's first to last message: 899 s
    assert report["detections"]["used"] == 2700  # what the warning is about: counted twice
    for apart in ((whole, later), (whole, brush)):
        report = build_json(*apart, "-o", tmp_path / "apart.aion", "--workers", "1")
        assert not [w for w in report["warnings"] if "count twice" in w]
    quiet = run("build", whole, excerpt, "-o", tmp_path / "q.aion", "-q")  # parallel too
    assert quiet.exit_code == 0
    assert "count twice" in quiet.stderr


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
