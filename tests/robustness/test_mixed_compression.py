"""Containers whose chunks differ from one another in one file, read back through every entry
point that reads logs: the stream (``LogSet.messages``, whole and by time range), the index
times a build's first pass uses (``LogSet.index_times``), ``aion info`` and ``aion build``.

MCAP files mix ``zstd``, ``lz4`` and uncompressed chunks, some
chunks without message indexes, summaries without some chunk indexes or none at all, and
messages outside chunks beside chunked ones (all valid MCAP). Every file is assembled record by
record (``tests/formats/craft.py``) around the messages a LogWriter wrote, so what must come
back is known exactly: those messages, byte for byte, in log-time order; and a map built from
the crafted file equals the map built from the LogWriter's own file. ROS 1 bags of mixed
chunks: ``test_mixed_compression_bags.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from aion_cli.formats.logs import open_logs
from tests.cli.conftest import run_json
from tests.formats.craft import McapFile, McapParts, mcap_parts, records_chunk
from tests.robustness.conftest import (
    T0,
    S,
    assert_same_arrays,
    build_json,
    map_arrays,
    robot_tf,
    run,
    walk,
    write_log,
)


def read_back(path: Path, topics: list[str]) -> dict[str, Any]:
    """What the stream, a time range of it and the index give for ``path``."""
    with open_logs([path]) as logs:
        messages = [(m.log_time_ns, bytes(m.data)) for m in logs.messages()]
        times = [t for t, _ in messages]
        lo, hi = times[len(times) // 4], times[3 * len(times) // 4]
        ranged = [m.log_time_ns for m in logs.messages(None, (lo, hi))]
        index = logs.index_times(topics, vouch=False)
        return {
            "messages": messages,
            "ranged": [t for t in ranged if lo <= t < hi],
            "wanted_range": [t for t in times if lo <= t < hi],
            "index": None if index is None else [int(t) for t in index.t],
            "span": (logs.start_ns, logs.end_ns),
            "total": logs.total(),
            "warnings": logs.warnings,
        }


def assert_same_map(crafted: Path, original: Path, tmp_path: Path, used: int) -> None:
    """``aion build`` of the crafted file uses ``used`` detections and makes the map the
    LogWriter's file makes (every array)."""
    a = build_json(crafted, "-o", tmp_path / "crafted.aion")
    b = build_json(original, "-o", tmp_path / "original.aion")
    assert a["detections"] == b["detections"] == {"read": used, "used": used, "dropped": {}}
    assert a["warnings"] == []
    crafted_map, original_map = tmp_path / "crafted.aion", tmp_path / "original.aion"
    assert_same_arrays(map_arrays(crafted_map), map_arrays(original_map))


# -- MCAP --------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def mcap(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, McapParts]:
    """60 person messages on /tracks and 60 TF messages on /tf, one of each a second (TF half
    a second later), as a LogWriter MCAP holds them; messages in log-time order."""
    tf = [robot_tf(T0 + k * S + S // 2) for k in range(60)]
    source = write_log(tmp_path_factory.mktemp("mcap") / "source.mcap", [*walk(60), *tf])
    parts = mcap_parts(source)
    parts.messages.sort(key=lambda m: m.log_time)
    return source, parts


PACKINGS = ["zstd", "lz4", "", "zstd", "", "lz4"]


def mixed_file(parts: McapParts, indexed: list[bool] | None = None) -> McapFile:
    """Six chunks of 20 messages, compressed in turn as ``PACKINGS`` says; ``indexed``: per
    chunk, whether its message index records follow it."""
    f = McapFile(parts)
    head = [*parts.schemas, *parts.channels]
    for k in range(6):
        records = [*(head if k == 0 else []), *parts.messages[20 * k : 20 * (k + 1)]]
        f.chunk(records_chunk(records, PACKINGS[k]), message_indexes=indexed is None or indexed[k])
    return f


def without_chunk_indexes(*positions: int) -> Any:
    def edit(summary: Any) -> None:
        for k in sorted(positions, reverse=True):
            del summary.chunk_indexes[k]

    return edit


SOME = [True, False, True, False, False, True]


@pytest.mark.parametrize(
    ("indexed", "edit", "with_summary", "from_index", "warned"),
    [
        (None, None, True, True, False),
        (None, None, False, True, False),
        (SOME, None, True, False, False),
        ([False] * 6, None, True, False, False),
        ([False] * 6, None, False, True, False),
        (None, without_chunk_indexes(2), True, True, True),
        (SOME, without_chunk_indexes(1, 4), True, True, True),
        (None, without_chunk_indexes(0, 1, 2, 3, 4, 5), True, True, False),
    ],
    ids=[
        "summary",
        "no-summary",
        "some-message-indexes",
        "no-message-indexes",
        "no-message-indexes-no-summary",
        "summary-without-a-chunk-index",
        "summary-without-two-some-message-indexes",
        "summary-without-chunk-indexes",
    ],
)
def test_mcap_chunks_of_mixed_compression(
    indexed: list[bool] | None,
    edit: Any,
    with_summary: bool,
    from_index: bool,
    warned: bool,
    mcap: tuple[Path, McapParts],
    tmp_path: Path,
) -> None:
    """Every message back from the stream and a time range, whatever the summary holds. The
    index gives the times when it can say all of them (a linear read counts the message
    indexes it walks past; a summary's chunks read through it need their message indexes),
    else None (the build reads the messages). A summary leaving out a chunk is said."""
    _, parts = mcap
    f = mixed_file(parts, indexed)
    path = f.write(tmp_path / "mixed.mcap", edit, with_summary=with_summary)
    got = read_back(path, ["/tracks", "/tf"])
    want = [(m.log_time, m.data) for m in parts.messages]
    assert got["messages"] == want
    assert got["ranged"] == got["wanted_range"]
    assert len(got["ranged"]) == 60
    assert got["index"] == ([t for t, _ in want] if from_index else None)
    assert got["span"] == (want[0][0], want[-1][0])
    assert got["total"] == 120
    if warned:
        (line,) = got["warnings"]
        assert "mixed.mcap: its summary disagrees with the data: " in line
        assert "are not in its chunk indexes" in line
        assert line.endswith("aion read the chunks themselves instead (linear scan): 120 messages")
    else:
        assert got["warnings"] == []
    info = run_json("info", path, "--format", "json")
    assert info["compression"] == ["lz4", "none", "zstd"]
    assert (info["messages"], info["start_ns"], info["end_ns"]) == (120, want[0][0], want[-1][0])


@pytest.mark.parametrize("packing", ["lz4", "zstd", ""])
@pytest.mark.parametrize("with_summary", [True, False], ids=["summary", "no-summary"])
def test_a_chunk_of_schemas_and_channels_only(
    packing: str, with_summary: bool, mcap: tuple[Path, McapParts], tmp_path: Path
) -> None:
    """A first chunk holding the schema and channel records and no message (no message
    index, start and end time 0: how the MCAP writers mark a chunk without messages; the C++
    writer closes one when a recording stops after a new topic's records), then the messages
    in zstd chunks. Its honest summary used to be reported as disagreeing with the data
    ("its statistics say the messages start at 2026-11-23T08:00:00.000000Z, its chunks at
    1970-01-01T00:00:00.000000Z") and the file read linearly. The index gives no times
    through the summary (that chunk has no message index: the build reads the messages)."""
    _, parts = mcap
    f = McapFile(parts).chunk(records_chunk([*parts.schemas, *parts.channels], packing))
    for k in range(0, 120, 30):
        f.chunk(records_chunk(parts.messages[k : k + 30], "zstd"))
    path = f.write(tmp_path / "defs.mcap", with_summary=with_summary)
    got = read_back(path, ["/tracks", "/tf"])
    want = [(m.log_time, m.data) for m in parts.messages]
    assert got["messages"] == want
    assert got["ranged"] == got["wanted_range"]
    assert got["index"] == (None if with_summary else [t for t, _ in want])
    assert got["span"] == (want[0][0], want[-1][0])
    assert got["warnings"] == []


def reversed_chunk_indexes(summary: Any) -> None:
    summary.chunk_indexes.reverse()


@pytest.mark.parametrize(
    ("order", "edit"),
    [
        ([0, 1, 2, 3], reversed_chunk_indexes),
        ([2, 0, 3, 1], None),
        ([2, 0, 3, 1], reversed_chunk_indexes),
    ],
    ids=["chunk-indexes-reversed", "chunks-out-of-time-order", "both"],
)
@pytest.mark.parametrize("with_summary", [True, False], ids=["summary", "no-summary"])
def test_mcap_chunks_and_chunk_indexes_out_of_order(
    order: list[int], edit: Any, with_summary: bool, mcap: tuple[Path, McapParts], tmp_path: Path
) -> None:
    """Four chunks (zstd, lz4, uncompressed, zstd in file order) holding the messages' 30s in
    ``order``; the summary's chunk indexes in file order or reversed. Every message comes
    back in time order from the stream and the index; chunks out of time order are said."""
    _, parts = mcap
    f = McapFile(parts)
    head = [*parts.schemas, *parts.channels]
    for k, part in enumerate(order):
        records = [*(head if k == 0 else []), *parts.messages[30 * part : 30 * part + 30]]
        f.chunk(records_chunk(records, ["zstd", "lz4", "", "zstd"][k]))
    path = f.write(tmp_path / "order.mcap", edit, with_summary=with_summary)
    got = read_back(path, ["/tracks", "/tf"])
    want = [(m.log_time, m.data) for m in parts.messages]
    assert got["messages"] == want
    assert got["ranged"] == got["wanted_range"]
    assert got["index"] == [t for t, _ in want]
    if order == sorted(order):
        assert got["warnings"] == []
    else:
        (line,) = got["warnings"]
        assert line.startswith("order.mcap: its log times go back at least 0.7 min")


def interleaved(parts: McapParts) -> McapFile:
    """Schemas and channels outside chunks, then by 20 messages: a zstd chunk, bare messages,
    an lz4 chunk, an uncompressed chunk, bare messages, a zstd chunk."""
    f = McapFile(parts)
    for record in [*parts.schemas, *parts.channels]:
        f.record(record)
    m = parts.messages
    f.chunk(records_chunk(m[0:20], "zstd"))
    for message in m[20:40]:
        f.record(message)
    f.chunk(records_chunk(m[40:60], "lz4"))
    f.chunk(records_chunk(m[60:80], ""))
    for message in m[80:100]:
        f.record(message)
    f.chunk(records_chunk(m[100:120], "zstd"))
    return f


@pytest.mark.parametrize("with_summary", [True, False], ids=["summary", "no-summary"])
def test_messages_outside_chunks_beside_chunked_ones(
    with_summary: bool, mcap: tuple[Path, McapParts], tmp_path: Path
) -> None:
    """Valid MCAP (the specification lets a writer put messages in chunks or not), which chunk
    indexes cannot list: read linearly, all 120 messages, and nothing said. Its honest summary
    used to be reported as disagreeing with the data ("40 message(s) outside chunks are not
    indexed") in ``aion info`` and every build."""
    _, parts = mcap
    path = interleaved(parts).write(tmp_path / "bare.mcap", with_summary=with_summary)
    got = read_back(path, ["/tracks", "/tf"])
    want = [(m.log_time, m.data) for m in parts.messages]
    assert got["messages"] == want
    assert got["ranged"] == got["wanted_range"]
    assert got["index"] == [t for t, _ in want]
    assert got["warnings"] == []
    info = run_json("info", path, "--format", "json")
    assert (info["compression"], info["messages"], info["warnings"]) == (
        ["lz4", "none", "zstd"], 120, []
    )


def test_statistics_that_count_only_chunked_messages_are_said(
    mcap: tuple[Path, McapParts], tmp_path: Path
) -> None:
    """The same file whose statistics leave the 40 bare messages out: every message read, and
    the statistics named as wrong (counted over the data section, not "its chunks")."""
    _, parts = mcap

    def chunked_only(summary: Any) -> None:
        stats = summary.statistics
        stats.message_count -= 40
        bare = parts.messages[20:40] + parts.messages[80:100]
        for m in bare:
            stats.channel_message_counts[m.channel_id] -= 1

    path = interleaved(parts).write(tmp_path / "bare.mcap", chunked_only)
    got = read_back(path, ["/tracks", "/tf"])
    assert len(got["messages"]) == 120
    assert got["warnings"] == [
        "bare.mcap: its statistics count 80 messages but its data section holds 120; aion "
        "read the chunks themselves (linear scan)"
    ]


def definitions_first(parts: McapParts) -> McapFile:
    """A chunk of the schemas and channels alone (lz4), then the messages in zstd chunks."""
    f = McapFile(parts).chunk(records_chunk([*parts.schemas, *parts.channels], "lz4"))
    for k in range(0, 120, 30):
        f.chunk(records_chunk(parts.messages[k : k + 30], "zstd"))
    return f


LAYOUTS = {"mixed": mixed_file, "interleaved": interleaved, "definitions-first": definitions_first}


@pytest.mark.parametrize("layout", list(LAYOUTS))
def test_a_mixed_mcap_builds_the_map_of_its_plain_twin(
    layout: str, mcap: tuple[Path, McapParts], tmp_path: Path
) -> None:
    source, parts = mcap
    f = LAYOUTS[layout](parts)
    path = f.write(tmp_path / f"{layout}.mcap")
    assert_same_map(path, source, tmp_path, 60)


def test_info_table_names_every_compression(mcap: tuple[Path, McapParts], tmp_path: Path) -> None:
    _, parts = mcap
    path = mixed_file(parts).write(tmp_path / "mixed.mcap")
    table = run("info", path)
    assert table.exit_code == 0, table.stderr
    assert "compression: lz4, none, zstd" in " ".join(table.stdout.split())
