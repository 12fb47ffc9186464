"""The joined payload buffer of :mod:`formats.detections.wire`, and fixed-width gathers from it.

:func:`join_payloads` joins the payloads of many messages into one ``uint8`` buffer (a
:class:`Joined`, with each message's payload bounds); :func:`block`, :func:`gather` and
:func:`gather_f64` copy fixed-width values at any absolute byte offsets out of it, through a
sliding-window view, so a gather at arbitrary (unaligned) offsets is one numpy fancy index.
A :class:`Joined` also counts the rounds :func:`~formats.detections.wire.walk` has run over it
(one budget per decode).

This is the byte layer under :class:`~formats.detections.wire.Cursors` and
:func:`~formats.detections.wire.walk`, which decide *where* to read; it knows nothing of
cursors, alignment rules or message layouts, so it lives apart (and imports nothing else of
``wire``, so there is no import cycle). ``wire`` re-exports every name defined here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from operator import attrgetter

import numpy as np
import numpy.typing as npt

from aion_cli.errors import MessageDecodeError
from aion_cli.formats.raw import RawMessage

U8 = npt.NDArray[np.uint8]
I64 = npt.NDArray[np.int64]
F64 = npt.NDArray[np.float64]

CDR_LE = b"\x00\x01"


@dataclass
class Joined:
    """The payloads of many messages in one buffer: ``start[i]``/``end[i]`` bound message i's
    payload (after the CDR encapsulation header), ``cdr`` tells which alignment rules apply."""

    buf: U8
    start: I64
    end: I64
    cdr: bool
    _windows: dict[int, npt.NDArray[np.void]] = field(default_factory=dict, repr=False)
    #: rounds :func:`walk` has run over this buffer, nested walks included (one budget,
    #: :data:`MAX_WALK_ROUNDS`, for the whole decode)
    walk_rounds: int = 0

    def windows(self, nbytes: int) -> npt.NDArray[np.void]:
        """Read-only view of ``nbytes``-byte items starting at every byte: item i = bytes
        i..i+nbytes (void dtype, stride 1), so a fancy index copies whole items."""
        w = self._windows.get(nbytes)
        if w is None:
            if nbytes > _TAIL + 1:
                raise ValueError(f"block reads are limited to {_TAIL + 1} bytes")
            w = np.ndarray(
                (len(self.buf) - nbytes + 1,), np.dtype((np.void, nbytes)), self.buf, 0, (1,)
            )
            self._windows[nbytes] = w
        return w


def join_payloads(messages: Sequence[RawMessage], cdr: bool) -> Joined:
    """Join the payloads of ``messages`` into one buffer (one ``bytes.join``).

    Raises :class:`MessageDecodeError` for a CDR message without a little-endian CDR header
    (the adapter then decodes the group with rosbags, which reads big-endian CDR too)."""
    datas = list(map(attrgetter("data"), messages))
    lens = np.fromiter(map(len, datas), dtype=np.int64, count=len(datas))
    data_start = np.cumsum(lens) - lens
    # Trailing zeros: the sliding windows of gather() may start at any byte of a payload.
    buf = np.frombuffer(b"".join([*datas, bytes(_TAIL)]), dtype=np.uint8)
    end = data_start + lens
    if not cdr:
        return Joined(buf, data_start, end, cdr)
    bad = (lens < 4) | (buf[data_start] != 0) | (buf[data_start + 1] != 1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        head = bytes(datas[i][:4])
        from aion_cli.formats.rosbag2_storage import ZSTD_MAGIC

        if head == ZSTD_MAGIC:  # rosbag2 message compression, read as a bare MCAP file
            raise MessageDecodeError(
                f"message {i} on {messages[i].topic!r} is zstd-compressed (starts with "
                f"{head.hex()}), not CDR",
                hint="a rosbag2 bag recorded with compression_mode: message: give its folder, "
                "or --log-format rosbag2 with the storage file alone",
            )
        raise MessageDecodeError(
            f"message {i} on {messages[i].topic!r} has no little-endian CDR header "
            f"(starts with {head.hex() or 'nothing'})"
        )
    return Joined(buf, data_start + 4, end, cdr)


#: Bytes appended to the joined buffer; the widest block read at once is _TAIL + 1 bytes.
_TAIL = 512


def block(j: Joined, off: I64, nbytes: int) -> U8:
    """``nbytes`` bytes at each absolute offset, as a contiguous uint8[len(off), nbytes] array.

    A sliding-window view of the buffer turns the gather into one fancy index over rows, for
    any alignment (ROS 1 fields are unaligned); callers check bounds first."""
    return j.windows(nbytes)[np.asarray(off, np.int64).ravel()].view(np.uint8).reshape(-1, nbytes)


def gather(j: Joined, off: I64, dtype: npt.DTypeLike) -> npt.NDArray[np.generic]:
    """Values of ``dtype`` (little-endian) at absolute byte offsets ``off`` (any alignment,
    any shape of ``off``)."""
    dt = np.dtype(dtype).newbyteorder("<")
    off = np.asarray(off, np.int64)
    return block(j, off.ravel(), dt.itemsize).view(dt).reshape(off.shape)


def gather_f64(j: Joined, off: I64, k: int) -> npt.NDArray[np.float64]:
    """``k`` consecutive little-endian float64 at each offset: float64[len(off), k]."""
    return block(j, off, 8 * k).view("<f8").reshape(-1, k).astype(np.float64, copy=False)
