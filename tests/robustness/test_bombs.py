"""Bounded resources (issue 14, point 6): a chunk that expands to a gigabyte costs megabytes.

The bombs are real: a 37 KB MCAP whose zstd chunk holds one message of 1 GiB of zeros, an 8 KB
ROS 1 bag whose bz2 chunk does the same; read naively they took 2.1 to 3.2 GB (see
docs/ROBUSTNESS.md). Each is crafted piece by piece (``tests/formats/craft.py``), next to
ordinary chunks whose messages must still come back. Memory is measured with ``tracemalloc``
(zstandard, lz4 and bz2 allocate their output as Python bytes, which it traces).
"""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from aion_cli.errors import ConfigError
from aion_cli.formats.limits import ReadLimits
from aion_cli.formats.logs import open_logs
from tests.formats.craft import McapFile, McapParts, mcap_parts, records_chunk, zeros_chunk
from tests.formats.craft_bag import bag_topic, craft_bag
from tests.robustness.conftest import assert_one_error, run, walk, write_log

MiB = 1 << 20
GiB = 1 << 30


def peak_mib(fn: Callable[[], Any]) -> tuple[Any, float]:
    """``fn()`` and the peak memory traced while it ran, in MiB."""
    tracemalloc.start()
    try:
        result = fn()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return result, peak / MiB


def read_everything(path: Path, limits: ReadLimits | None = None) -> dict[str, Any]:
    """What a build asks of a log: topics and counts, every message, the recorded windows."""
    with open_logs([path], limits=limits) as logs:
        sizes = [(m.log_time_ns, len(m.data)) for m in logs.messages()]
        windows = logs.recorded_windows(600 * 10**9)
        return {
            "counts": {t.topic: t.count for t in logs.topics},
            "sizes": sizes,
            "windows": windows.tolist(),
            "warnings": logs.warnings,
        }


@pytest.fixture(scope="module")
def parts(tmp_path_factory: pytest.TempPathFactory) -> McapParts:
    found = mcap_parts(write_log(tmp_path_factory.mktemp("bomb") / "src.mcap", walk(20)))
    found.messages.sort(key=lambda m: m.log_time)
    return found


def bomb_file(
    parts: McapParts, path: Path, payload: int, *, summary: bool = True, **kw: Any
) -> McapFile:
    """Ten messages, a chunk holding one message of ``payload`` zero bytes (``kw`` to
    :func:`zeros_chunk`), ten more messages."""
    cid = parts.channels[0].id
    msgs = parts.messages
    f = McapFile(parts)
    f.chunk(records_chunk([*parts.schemas, *parts.channels, *msgs[:10]]))
    f.chunk(zeros_chunk(cid, msgs[10].log_time - 1, payload, **kw))
    f.chunk(records_chunk(msgs[10:]))
    f.write(path, with_summary=summary)
    return f


@pytest.mark.parametrize("summary", [True, False], ids=["indexed", "linear"])
def test_a_chunk_declaring_a_gigabyte_is_skipped_before_decompressing(
    summary: bool, parts: McapParts, tmp_path: Path
) -> None:
    path = tmp_path / "bomb.mcap"
    f = bomb_file(parts, path, GiB, summary=summary)
    assert path.stat().st_size < 40_000
    got, peak = peak_mib(lambda: read_everything(path))
    assert peak < 16, peak  # was 2,080 MiB (linear) / 3,151 MiB RSS in a build
    assert [t for t, _ in got["sizes"]] == [m.log_time for m in parts.messages]
    assert got["counts"] == {"/tracks": 20}  # the refused message is not counted
    (line,) = got["warnings"]
    assert line == (
        f"bomb.mcap: chunk at byte {f.chunk_offsets[1]} skipped: it declares 1,024 MiB "
        "uncompressed, over the 512 MiB limit per chunk "
        "(raise it with aion --max-chunk-mb or AION_MAX_CHUNK_MB); "
        "1 message lost (/tracks 1)"
    )


@pytest.mark.parametrize(
    ("compression", "frame_size"),
    [("zstd", True), ("zstd", False), ("lz4", False)],
    ids=["zstd-frame-size", "zstd-no-frame-size", "lz4"],
)
def test_a_chunk_that_expands_beyond_what_it_declares_is_cut_off(
    compression: str, frame_size: bool, parts: McapParts, tmp_path: Path
) -> None:
    """The chunk says 1 KiB; its data expands to 1 GiB (256 MiB for lz4). Decompression asks
    for 1 KiB + 1 byte, so the lie costs nothing (the zstd frame header may even state the
    true size: it is not what decides the allocation)."""
    path = tmp_path / "liar.mcap"
    payload = GiB if compression == "zstd" else 256 * MiB
    kw = {"declared_size": 1024, "frame_size": frame_size}
    f = bomb_file(parts, path, payload, compression=compression, **kw)
    got, peak = peak_mib(lambda: read_everything(path))
    assert peak < 16, peak
    assert [t for t, _ in got["sizes"]] == [m.log_time for m in parts.messages]
    (line,) = got["warnings"]
    assert line.startswith(f"liar.mcap: corrupt chunk at byte {f.chunk_offsets[1]} skipped: ")
    assert f"its {compression} data expands beyond the 1,024 bytes it declares" in line


def test_the_chunk_cap_is_raised_by_the_environment_or_the_keyword(
    parts: McapParts, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "big.mcap"
    bomb_file(parts, path, 16 * MiB)  # an honest 16 MiB chunk
    monkeypatch.setenv("AION_MAX_CHUNK_MB", "8")
    got = read_everything(path)
    assert len(got["sizes"]) == 20
    (line,) = got["warnings"]
    assert (
        "declares 16 MiB uncompressed, over the 8 MiB limit per chunk "
        "(raise it with aion --max-chunk-mb"
        in line
    )
    monkeypatch.setenv("AION_MAX_CHUNK_MB", "32")
    got = read_everything(path)
    assert got["warnings"] == []
    assert sorted(size for _, size in got["sizes"])[-1] == 16 * MiB  # read whole
    monkeypatch.setenv("AION_MAX_CHUNK_MB", "8")
    got = read_everything(path, ReadLimits.of(max_chunk_mb=32))  # the keyword wins
    assert len(got["sizes"]) == 21


def test_a_chunk_without_a_declared_size_is_bounded_by_the_cap(
    parts: McapParts, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A writer that leaves the uncompressed size 0 (unknown): decompression stops at the cap."""
    path = tmp_path / "unsized.mcap"
    bomb_file(parts, path, 256 * MiB, declared_size=0, frame_size=False)
    monkeypatch.setenv("AION_MAX_CHUNK_MB", "8")
    got, peak = peak_mib(lambda: read_everything(path))
    assert peak < 24, peak
    assert len(got["sizes"]) == 20
    (line,) = got["warnings"]
    assert (
        "it expands beyond the 8 MiB limit per chunk "
        "(raise it with aion --max-chunk-mb or AION_MAX_CHUNK_MB"
        in line
    )


@pytest.mark.parametrize("chunked", [True, False], ids=["in-a-chunk", "outside-chunks"])
def test_a_message_over_the_message_cap_is_skipped_and_said(
    chunked: bool, parts: McapParts, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "big-message.mcap"
    cid = parts.channels[0].id
    big = zeros_chunk(cid, parts.messages[5].log_time + 1, 2 * MiB)
    f = McapFile(parts)
    if chunked:
        f.chunk(records_chunk([*parts.schemas, *parts.channels, *parts.messages[:10]]))
        f.chunk(big)
        f.chunk(records_chunk(parts.messages[10:]))
        path.write_bytes(f.bytes())
    else:  # an unchunked file: records in the data section, no summary
        from mcap.records import Message

        for record in [*parts.schemas, *parts.channels, *parts.messages[:10]]:
            f.record(record)
        t = parts.messages[5].log_time + 1
        f.record(
            Message(channel_id=cid, log_time=t, data=bytes(2 * MiB), publish_time=t, sequence=0)
        )
        for record in parts.messages[10:]:
            f.record(record)
        path.write_bytes(f.bytes(with_summary=False))
    monkeypatch.setenv("AION_MAX_MESSAGE_MB", "1")
    got = read_everything(path)
    assert [t for t, _ in got["sizes"]] == [m.log_time for m in parts.messages]
    (line,) = got["warnings"]
    assert line == (
        "big-message.mcap: a message on /tracks at 2026-11-23T08:00:05.000000Z skipped: "
        "2 MiB, over the 1 MiB limit per message "
        "(raise it with aion --max-message-mb or AION_MAX_MESSAGE_MB)"
    )
    monkeypatch.delenv("AION_MAX_MESSAGE_MB")
    assert len(read_everything(path)["sizes"]) == 21


def test_the_chunk_cap_is_raised_by_the_command_line_flag(
    parts: McapParts, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``aion --max-chunk-mb 32 info`` reads the honest 16 MiB chunk the 8 MiB environment cap
    refuses (the flag wins); a flag that is not a positive size is one error line, exit 2."""
    path = tmp_path / "big.mcap"
    bomb_file(parts, path, 16 * MiB)
    monkeypatch.setenv("AION_MAX_CHUNK_MB", "8")  # restored after the test, whatever the flag set
    refused = run("info", path)
    assert refused.exit_code == 0, refused.stderr
    assert "over the 8 MiB limit per chunk (raise it with aion --max-chunk-mb" in refused.stderr
    raised = run("--max-chunk-mb", "32", "info", path)
    assert raised.exit_code == 0, raised.stderr
    assert "limit per chunk" not in raised.stderr
    bad = run("--max-chunk-mb", "-1", "info", path)
    assert bad.exit_code == 2
    assert_one_error(bad.stderr, "the chunk limit must be a positive number of megabytes")


def test_a_bad_cap_in_the_environment_is_one_error_line(
    parts: McapParts, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "small.mcap"
    bomb_file(parts, path, 10)
    for value in ("abc", "0", "-5", "nan", "1e300"):
        monkeypatch.setenv("AION_MAX_CHUNK_MB", value)
        with pytest.raises(ConfigError, match="AION_MAX_CHUNK_MB must be a positive number"):
            open_logs([path])
    monkeypatch.setenv("AION_MAX_CHUNK_MB", "abc")
    result = run("info", path)
    assert result.exit_code == 2
    assert_one_error(
        result.stderr, "AION_MAX_CHUNK_MB must be a positive number of megabytes (MiB), got 'abc'"
    )


def test_the_linear_bomb_through_aion_info_takes_megabytes(
    parts: McapParts, tmp_path: Path
) -> None:
    """`aion info` on the bomb without a summary (its opening scan decompressed every chunk:
    2,080 MiB)."""
    path = tmp_path / "bomb.mcap"
    bomb_file(parts, path, GiB, summary=False)
    result, peak = peak_mib(lambda: run("info", path))
    assert result.exit_code == 0, result.stderr
    assert peak < 32, peak
    assert "warning: bomb.mcap: chunk at byte" in result.stderr
    assert (
        "over the 512 MiB limit per chunk (raise it with aion --max-chunk-mb or AION_MAX_CHUNK_MB"
        in result.stderr
    )


# -- ROS 1 bags ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def bag_parts(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, list[tuple[int, bytes]]]:
    source = write_log(tmp_path_factory.mktemp("bag") / "src.bag", walk(20), "bag")
    return bag_topic(source, "/tracks")


@pytest.fixture(scope="module")
def bag_bomb(
    tmp_path_factory: pytest.TempPathFactory, bag_parts: tuple[Any, list[tuple[int, bytes]]]
) -> Path:
    """An 8 KB bag: a bz2 chunk of ten messages and one of 1 GiB zeros (its size field says
    so), then a chunk of ten more (crafting it takes about 6 s of bz2)."""
    topic, msgs = bag_parts
    path = tmp_path_factory.mktemp("bag") / "bomb.bag"
    path.write_bytes(craft_bag(topic, [msgs[:10], msgs[10:]], "bz2", bomb=(0, GiB)))
    return path


@pytest.mark.slow
def test_a_bag_chunk_declaring_a_gigabyte_is_refused_at_open(
    bag_bomb: Path, bag_parts: tuple[Any, list[tuple[int, bytes]]]
) -> None:
    _, msgs = bag_parts
    assert bag_bomb.stat().st_size < 10_000
    got, peak = peak_mib(lambda: read_everything(bag_bomb))
    assert peak < 16, peak  # was 2,128 MiB RSS in a build
    assert [t for t, _ in got["sizes"]] == [t for t, _ in msgs[10:]]  # the other chunk
    (line,) = got["warnings"]
    assert line.startswith("bomb.bag: chunk at byte 4109 skipped: it declares 1,024 MiB ")
    assert line.endswith(
        "(raise it with aion --max-chunk-mb or AION_MAX_CHUNK_MB); 11 messages lost (/tracks 11)"
    )


def test_a_bag_chunk_whose_size_field_lies_is_cut_off(
    tmp_path: Path, bag_parts: tuple[Any, list[tuple[int, bytes]]]
) -> None:
    """The size field says 1 KiB; the bz2 data expands to 64 MiB: decompression stops after
    1 KiB + 1 byte and the chunk is skipped, the next one read."""
    topic, msgs = bag_parts
    path = tmp_path / "liar.bag"
    data = craft_bag(
        topic, [msgs[:10], msgs[10:]], "bz2", bomb=(0, 64 * MiB), declared_sizes=[1024, None]
    )
    path.write_bytes(data)
    got, peak = peak_mib(lambda: read_everything(path))
    assert peak < 8, peak
    assert [t for t, _ in got["sizes"]] == [t for t, _ in msgs[10:]]
    (line,) = got["warnings"]
    assert "its bz2 data expands beyond the 1,024 bytes it declares" in line
    assert line.endswith("; 11 messages lost (/tracks 11)")
