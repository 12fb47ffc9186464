"""Caps on what one chunk or one message of a log may expand to in memory, and decompression that
never produces more than it is allowed to.

A 33 KB MCAP file can hold a zstd chunk that expands to a gigabyte, a 6 KB ROS 1 bag a bz2 chunk
of the same size: read naively, each takes gigabytes of memory for nothing. The readers
(:mod:`formats.mcap_source`, :mod:`formats.bag_reader`) therefore check the uncompressed size a
chunk declares before decompressing it, and decompress with a bounded output (zstd and lz4
frames, bz2 streams), so that a header that lies about the size cannot blow up either: a chunk
that expands beyond what it declares is refused after at most ``declared + 1`` bytes.

Defaults: 512 MiB per chunk (:data:`DEFAULT_MAX_CHUNK_MB`), 256 MiB per message
(:data:`DEFAULT_MAX_MESSAGE_MB`): far above what recorders write (MCAP writers default to 1 to
4 MiB chunks, ROS 1 bags to 768 KiB) and below what would hurt a workstation. Raise them with the
environment variables ``AION_MAX_CHUNK_MB`` / ``AION_MAX_MESSAGE_MB`` (megabytes, MiB) or the
``limits`` keyword of :func:`formats.logs.open_logs`. A chunk over its cap is skipped with a
warning naming it and the messages lost; so is a message over its cap.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from aion_cli.errors import ConfigError

MIB = 1 << 20
DEFAULT_MAX_CHUNK_MB = 512
DEFAULT_MAX_MESSAGE_MB = 256
CHUNK_ENV = "AION_MAX_CHUNK_MB"
MESSAGE_ENV = "AION_MAX_MESSAGE_MB"
#: the largest cap accepted: more than any machine's memory, and below 2**63 bytes
_MAX_MB = 1 << 30


class ChunkError(ValueError):
    """A chunk (or message) that cannot be read: over its cap, expanding beyond the size it
    declares, in an unknown compression, or damaged. ``str()`` says why in a few words."""


class OverLimitError(ChunkError):
    """A chunk or message larger than the cap (``env`` names the variable that raises it)."""

    def __init__(self, message: str, env: str) -> None:
        super().__init__(message)
        self.env = env


class UnknownCompressionError(ChunkError):
    """A chunk compressed with a method aion cannot decompress."""


def _megabytes(value: object, name: str, example: str = "2048") -> int:
    """``value`` (MiB, a number or its text) as bytes; :class:`ConfigError` when it is not a
    positive number, with ``example`` as the hint's (``AION_MAX_CHUNK_MB=2048`` for the
    environment variable, the number alone for an option or argument)."""
    try:
        mb = float(str(value).strip())
    except ValueError:
        mb = math.nan
    if not (math.isfinite(mb) and 0 < mb <= _MAX_MB):
        raise ConfigError(
            f"{name} must be a positive number of megabytes (MiB), got {value!r}",
            hint=f"e.g. {example} for 2 GiB",
        )
    return max(int(mb * MIB), 1)


@dataclass(frozen=True)
class ReadLimits:
    """What one decompressed chunk and one message may take, in bytes."""

    max_chunk_bytes: int = DEFAULT_MAX_CHUNK_MB * MIB
    max_message_bytes: int = DEFAULT_MAX_MESSAGE_MB * MIB

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> ReadLimits:
        """The defaults, or ``AION_MAX_CHUNK_MB`` / ``AION_MAX_MESSAGE_MB`` where set (empty
        means unset); :class:`ConfigError` for a value that is not a positive number."""
        env = os.environ if environ is None else environ
        chunk, message = env.get(CHUNK_ENV, "").strip(), env.get(MESSAGE_ENV, "").strip()
        return cls(
            _megabytes(chunk, CHUNK_ENV, f"{CHUNK_ENV}=2048") if chunk
            else DEFAULT_MAX_CHUNK_MB * MIB,
            _megabytes(message, MESSAGE_ENV, f"{MESSAGE_ENV}=2048") if message
            else DEFAULT_MAX_MESSAGE_MB * MIB,
        )

    @classmethod
    def of(
        cls, max_chunk_mb: float | None = None, max_message_mb: float | None = None
    ) -> ReadLimits:
        """The limits a caller (the CLI) gives in MiB; None takes the environment's or the
        default."""
        base = cls.from_env()
        return cls(
            base.max_chunk_bytes
            if max_chunk_mb is None
            else _megabytes(max_chunk_mb, "the chunk limit"),
            base.max_message_bytes
            if max_message_mb is None
            else _megabytes(max_message_mb, "the message limit"),
        )


def mib(n: int) -> str:
    """``n`` bytes as a short MiB figure for messages (``1,024 MiB``, ``0.5 MiB``)."""
    value = n / MIB
    return f"{value:,.0f} MiB" if value >= 10 else f"{value:,.2g} MiB"


def chunk_over_limit(size: int, limit: int) -> OverLimitError:
    return OverLimitError(
        f"it declares {mib(size)} uncompressed, over the {mib(limit)} limit per chunk "
        f"(raise it with aion --max-chunk-mb or {CHUNK_ENV})",
        CHUNK_ENV,
    )


def message_over_limit(size: int, limit: int) -> OverLimitError:
    return OverLimitError(
        f"{mib(size)}, over the {mib(limit)} limit per message "
        f"(raise it with aion --max-message-mb or {MESSAGE_ENV})",
        MESSAGE_ENV,
    )


#: compression names of MCAP chunks (``""``) and ROS 1 bag chunks (``"none"``)
_PLAIN = ("", "none")
KNOWN_COMPRESSIONS = ("", "none", "zstd", "lz4", "bz2")


def decompress(data: bytes | memoryview, compression: str, declared: int, limit: int) -> bytes:
    """The ``declared`` bytes that ``data`` decompresses to (``compression``: ``zstd``,
    ``lz4``, ``bz2``, or ``""`` / ``"none"`` for stored data).

    The declared size is checked against ``limit`` before anything is decompressed, and
    decompression asks for at most ``declared + 1`` bytes, so neither a chunk that declares too
    much nor one that expands beyond what it declares costs more than ``limit``. ``declared``
    0 means unknown (a writer that does not fill it in): then at most ``limit`` bytes.

    Raises :class:`OverLimitError`, :class:`UnknownCompressionError`, or :class:`ChunkError`
    for damaged data and data that does not decompress to the declared size.
    """
    if declared > limit:
        raise chunk_over_limit(declared, limit)
    if compression in _PLAIN:
        if len(data) > limit:
            raise chunk_over_limit(len(data), limit)
        return bytes(data)
    if compression not in KNOWN_COMPRESSIONS:
        raise UnknownCompressionError(f"unknown compression {compression[:40]!r}")
    bound = declared if declared > 0 else limit
    try:
        out = _bounded(compression, data, bound + 1)
    except ChunkError:
        raise
    except Exception as exc:  # zstandard.ZstdError, lz4's RuntimeError, bz2's OSError / EOFError
        raise ChunkError(f"cannot decompress its {compression} data ({exc})") from exc
    if len(out) > bound:
        if declared > 0:
            failed = _fails_further(compression, data, min(bound + _PROBE, limit) + 1)
            raise ChunkError(
                f"cannot decompress its {compression} data ({failed})"
                if failed is not None
                else f"its {compression} data expands beyond the {declared:,} bytes it declares"
            )
        raise OverLimitError(
            f"it expands beyond the {mib(limit)} limit per chunk "
            f"(raise it with aion --max-chunk-mb or {CHUNK_ENV})",
            CHUNK_ENV,
        )
    if declared > 0 and len(out) != declared:
        raise ChunkError(
            f"its {compression} data ends after {len(out):,} of the {declared:,} bytes it "
            "declares (truncated or damaged)"
        )
    return out


#: How far past its declared size a chunk is decompressed to tell damaged data from a wrong
#: size: damaged bz2 data fails its block's CRC within a block (at most 900 kB out), lz4 and
#: zstd data at a checksum; data that goes on without an error expands beyond what it says.
_PROBE = MIB


def _fails_further(compression: str, data: bytes | memoryview, most: int) -> str | None:
    """Why ``data`` cannot be decompressed within ``most`` bytes out, or None if it can."""
    try:
        _bounded(compression, data, most)
    except Exception as exc:  # as in decompress: each library's own error
        return str(exc)
    return None


def _bounded(compression: str, data: bytes | memoryview, most: int) -> bytes:
    """At most ``most`` bytes of decompressed ``data``."""
    if compression == "zstd":
        reader = zstd_decompressor().stream_reader(bytes(data), read_across_frames=True)
        return bytes(reader.read(most))
    if compression == "lz4":
        import lz4.frame  # type: ignore[import-untyped]

        lz4_obj = lz4.frame.LZ4FrameDecompressor()
        return bytes(lz4_obj.decompress(bytes(data), max_length=most))
    import bz2

    bz2_obj = bz2.BZ2Decompressor()
    return bytes(bz2_obj.decompress(bytes(data), max_length=most))


_THREAD = threading.local()


def zstd_decompressor() -> Any:
    """This thread's ``zstandard.ZstdDecompressor``, made once and used for every zstd chunk
    the thread reads (:func:`decompress`, ``formats.mcap_partial``'s chunk heads).

    Why: a new decompressor allocates its context and, for a streamed frame, a window buffer
    of up to the frame's size, and the first touch of fresh pages is dear on this kind of VM
    (docs/BENCHMARKS.md); a live Hydra log reads ~3,600 chunks an hour. Reusing one is
    exact: each ``stream_reader`` starts a new session on it (zstandard resets the context's
    session, not its parameters, which are the defaults here), whether the last read ended,
    stopped early (a chunk's head) or failed on damaged data (tested). One per thread: a
    decompressor must not serve two threads at once, and a caller may read logs from
    several."""
    dctx = getattr(_THREAD, "zstd", None)
    if dctx is None:
        import zstandard

        dctx = _THREAD.zstd = zstandard.ZstdDecompressor()
    return dctx
