"""The zstd side of reading a chunk up to a tail (issue 15, :mod:`formats.mcap_partial`;
the streams themselves: ``test_mcap_partial.py``): a chunk's head is decompressed from a few
reads, never past the chunk's data, and the thread's reused decompressor gives each chunk its
own bytes whatever the read before it did."""

from __future__ import annotations

from typing import Any

import pytest

from aion_cli.formats import mcap_partial


def test_a_zstd_head_reads_only_what_it_needs_and_never_past_its_data() -> None:
    """The head of a chunk whose tail is megabytes of graph: the first bytes come out right,
    only a few reads of compressed data are taken (not the whole chunk), nothing past the
    chunk's data (the next record) is read, and data cut short gives fewer bytes."""
    import io
    import os

    import zstandard

    raw = b"head" * 500 + os.urandom(1 << 20)  # a compressible head, an incompressible tail
    frame = zstandard.ZstdCompressor().compress(raw)
    after = b"next record, not zstd"
    f = io.BytesIO(b"x" * 7 + frame + after)
    reads = []
    window = mcap_partial._Window(f, 7, len(frame))
    original = window.read

    def counted(size: int = -1) -> bytes:
        data = original(size)
        reads.append(len(data))
        return data

    window.read = counted  # type: ignore[method-assign]
    assert mcap_partial._zstd_prefix(window, 2000) == raw[:2000]
    assert sum(reads) <= 2 * mcap_partial._ZSTD_READ < len(frame)
    whole = mcap_partial._Window(f, 7, len(frame))
    assert mcap_partial._zstd_prefix(whole, len(raw) + 10) == raw  # stops at the data's end
    assert whole.pos == 7 + len(frame)
    short = mcap_partial._Window(f, 7, len(frame) // 2)
    assert len(mcap_partial._zstd_prefix(short, len(raw))) < len(raw)


def test_one_zstd_decompressor_per_thread_reads_every_chunk_after_any_other() -> None:
    """The thread's reused decompressor (``limits.zstd_decompressor``) gives each chunk its own
    bytes whatever the read before it did: a head stopped early, a whole chunk, damaged data
    that failed; another thread gets a decompressor of its own."""
    import io
    import os
    import threading

    import zstandard

    from aion_cli.formats import limits

    raws = [b"a" * 3000 + os.urandom(200_000), b"bb" * 50_000, os.urandom(70_000) + b"c" * 900]
    frames = [zstandard.ZstdCompressor().compress(r) for r in raws]
    damaged = bytearray(frames[0])
    damaged[len(damaged) // 2 :] = bytes(len(damaged) - len(damaged) // 2)
    mine = limits.zstd_decompressor()
    assert limits.zstd_decompressor() is mine

    def head(k: int, n: int) -> bytes:
        return mcap_partial._zstd_prefix(
            mcap_partial._Window(io.BytesIO(frames[k]), 0, len(frames[k])), n
        )

    def whole(k: int) -> bytes:
        return limits.decompress(frames[k], "zstd", len(raws[k]), 1 << 24)

    assert head(0, 100) == raws[0][:100]  # stopped early, the session left open
    assert whole(1) == raws[1]
    with pytest.raises(limits.ChunkError):
        limits.decompress(bytes(damaged), "zstd", len(raws[0]), 1 << 24)
    assert head(2, 70_500) == raws[2][:70_500]
    assert whole(0) == raws[0]
    assert whole(2) == raws[2]
    other: list[Any] = []
    thread = threading.Thread(target=lambda: other.append((limits.zstd_decompressor(), whole(1))))
    thread.start()
    thread.join()
    assert other[0][0] is not mine
    assert other[0][1] == raws[1]
