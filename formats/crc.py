"""CRC-32 (the zlib / ZIP / MCAP polynomial) at the speed of the machine.

Every MCAP chunk aion reads is checked against its CRC-32 (a flipped bit in compressed data
often still decompresses, into garbage). ``zlib.crc32`` runs at about 2.4 GB/s on the
development machine, which made the check about 5 % of a build at 25 people per message and
a quarter of reading a log of large scene graphs (docs/BENCHMARKS.md); Intel's ISA-L
(``isal``, carry-less multiply) computes the same value at about 10 GB/s. :func:`crc32` uses
it where its wheel is installed (x86-64 and ARM64) and ``zlib.crc32`` elsewhere: the same
checksum either way (tested).
"""

from __future__ import annotations

from collections.abc import Callable

Bytes = bytes | bytearray | memoryview


def _best() -> tuple[Callable[[Bytes, int], int], str]:
    try:
        from isal.isal_zlib import crc32 as fast
    except ImportError:  # no wheel for this platform: the standard library's
        from zlib import crc32 as plain

        return plain, "zlib"
    return fast, "isal"


_CRC32, BACKEND = _best()
"""The implementation in use and its name (``"isal"`` or ``"zlib"``)."""


def crc32(data: Bytes, value: int = 0) -> int:
    """The CRC-32 of ``data`` (continuing ``value``), as ``zlib.crc32`` computes it."""
    return _CRC32(data, value)
