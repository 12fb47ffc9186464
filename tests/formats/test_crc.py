"""CRC-32 of MCAP chunks: the fast implementation gives zlib's checksum for any bytes, and a
chunk whose records were altered is still refused."""

from __future__ import annotations

import importlib.util
import zlib

import pytest
from hypothesis import given
from hypothesis import strategies as st

from aion_cli.formats import crc


@given(st.binary(max_size=5000), st.integers(0, 2**32 - 1))
def test_crc32_is_zlibs_for_any_bytes_and_start_value(data: bytes, start: int) -> None:
    assert crc.crc32(data, start) == zlib.crc32(data, start)
    assert crc.crc32(memoryview(data)) == zlib.crc32(data)
    assert crc.crc32(bytearray(data)) == zlib.crc32(data)


def test_crc32_of_a_large_buffer_in_pieces_equals_whole() -> None:
    data = bytes(range(256)) * 40_000  # 10 MB: the vectorised path, not a short-input one
    whole = crc.crc32(data)
    assert whole == zlib.crc32(data)
    assert crc.crc32(data[5_000_001:], crc.crc32(data[:5_000_001])) == whole


def test_the_fast_backend_is_used_where_isal_is_installed() -> None:
    if importlib.util.find_spec("isal") is None:
        pytest.skip("isal has no wheel for this platform: zlib.crc32 is used, tested above")
    assert crc.BACKEND == "isal"
