"""Vectorized reading of many serialized messages at once, straight from their bytes.

All payloads of one call are joined into a single ``uint8`` buffer; a :class:`Cursors` object
holds one read position per message (or per array element) and every read (``u32``, ``f64``,
``string``) advances all of them together with numpy gathers. Two wire formats:

- ROS 2 CDR: a 4-byte encapsulation header (``00 01 00 00`` = little-endian CDR), then the
  payload; a primitive of size w is aligned to w relative to the payload start (8 for
  float64/uint64, 4 for uint32 and sequence/string lengths); a string is a uint32 length that
  counts its NUL terminator, then the bytes.
- ROS 1: no header, no alignment, little-endian, uint32 lengths, strings without a NUL.

Reads use a sliding-window view of the joined buffer, so a gather of fixed-width fields at
arbitrary (unaligned) offsets is one numpy fancy index. Every read is bounds-checked against its
own message's end, so truncated or garbage input raises :class:`MessageDecodeError` rather than
``IndexError`` or values from the neighbouring message.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from operator import attrgetter

import numpy as np
import numpy.typing as npt

from aion_cli.engine.errors import MessageDecodeError
from formats.raw import RawMessage

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
        raise MessageDecodeError(
            f"message {i} on {messages[i].topic!r} has no little-endian CDR header "
            f"(starts with {bytes(datas[i][:4]).hex() or 'nothing'})"
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


class Cursors:
    """Read positions advancing in lock-step over many messages or elements.

    ``base`` is the alignment origin (payload start) of each cursor, ``pos`` the current
    absolute position, ``end`` the absolute end of its message, ``msg`` its message index (for
    error messages). All reads check ``pos + size <= end`` first."""

    def __init__(self, j: Joined, base: I64, pos: I64, end: I64, msg: I64, what: str) -> None:
        self.j = j
        self.base = base
        self.pos = pos
        self.end = end
        self.msg = msg
        self.what = what

    @classmethod
    def over_messages(cls, j: Joined, what: str) -> Cursors:
        n = len(j.start)
        return cls(j, j.start.copy(), j.start.copy(), j.end.copy(), np.arange(n), what)

    def __len__(self) -> int:
        return len(self.pos)

    def subset(self, mask: npt.NDArray[np.bool_]) -> Cursors:
        """The cursors where ``mask`` is true (copies; write back with :meth:`merge`)."""
        return Cursors(
            self.j, self.base[mask], self.pos[mask].copy(), self.end[mask], self.msg[mask],
            self.what,
        )

    def merge(self, mask: npt.NDArray[np.bool_], sub: Cursors) -> None:
        self.pos[mask] = sub.pos

    def repeat(self, counts: I64, first: I64, stride: int) -> Cursors:
        """One cursor per array element: cursor i is repeated ``counts[i]`` times, element k
        starting at ``first[i] + k * stride`` (fixed-size elements)."""
        total = int(counts.sum())
        owner = np.repeat(np.arange(len(counts)), counts)
        k = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
        pos = first[owner] + k * stride
        return Cursors(self.j, self.base[owner], pos, self.end[owner], self.msg[owner], self.what)

    # --- checks -----------------------------------------------------------------------------
    def fail(self, bad: npt.NDArray[np.bool_], problem: str) -> None:
        """Raise for the first cursor in ``bad`` (if any)."""
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise MessageDecodeError(
                f"cannot decode {self.what} message {int(self.msg[i])}: {problem} at byte "
                f"{int(self.pos[i] - self.base[i])} of {int(self.end[i] - self.base[i])}",
                hint="the payload is truncated, corrupt or not of this message type",
            )

    def need(self, nbytes: I64 | int) -> None:
        self.fail(self.pos + nbytes > self.end, "payload ends early")

    def align(self, w: int) -> None:
        if self.j.cdr and w > 1:
            rel = self.pos - self.base
            self.pos = self.base + ((rel + (w - 1)) // w) * w

    def aligned(self, w: int, first: I64 | None = None) -> I64:
        """Positions aligned to ``w`` without moving the cursors."""
        p = self.pos if first is None else first
        if not self.j.cdr or w == 1:
            return p
        return self.base + ((p - self.base + (w - 1)) // w) * w

    # --- reads --------------------------------------------------------------------------------
    def scalar(self, dtype: npt.DTypeLike) -> npt.NDArray[np.generic]:
        dt = np.dtype(dtype)
        self.align(dt.itemsize)
        self.need(dt.itemsize)
        out = gather(self.j, self.pos, dt)
        self.pos = self.pos + dt.itemsize
        return out

    def u32(self) -> I64:
        return self.scalar(np.uint32).astype(np.int64)

    def f64(self, k: int) -> F64:
        """``k`` consecutive float64 per cursor, shape (n, k)."""
        self.align(8)
        self.need(8 * k)
        out = gather_f64(self.j, self.pos, k)
        self.pos = self.pos + 8 * k
        return out

    def skip(self, nbytes: int, align: int = 1) -> None:
        self.align(align)
        self.need(nbytes)
        self.pos = self.pos + nbytes

    def string(self) -> tuple[I64, I64]:
        """A string per cursor: (absolute start, length without NUL) of its bytes."""
        n = self.u32()
        self.need(n)
        start = self.pos
        self.pos = self.pos + n
        if self.j.cdr:
            length = np.maximum(n - 1, 0)
        else:
            length = n
        return start, length

    def count(self, elem_size: int) -> I64:
        """A sequence length, checked against the bytes left (each element >= elem_size)."""
        n = self.u32()
        self.fail(n * elem_size > self.end - self.pos, "sequence length exceeds the payload")
        return n

    def skip_strings(self, counts: I64) -> None:
        """Skip ``counts[i]`` strings at each cursor (a string[] body)."""
        active = counts > 0
        k = 0
        while active.any():
            sub = self.subset(active)
            sub.string()
            self.merge(active, sub)
            k += 1
            active = counts > k

    def skip_bytes_seq(self, elem: int) -> None:
        """Skip a primitive sequence of ``elem``-byte items (e.g. uint8[] data)."""
        n = self.count(elem)
        has = n > 0
        if has.any():
            self.pos = np.where(has, self.aligned(elem), self.pos)
        self.need(n * elem)
        self.pos = self.pos + n * elem

    def check_consumed(self) -> None:
        """The message must end here: exactly for ROS 1, within CDR's trailing padding (< 8
        bytes) for CDR. Catches a different layout of the same type name."""
        left = self.end - self.pos
        slack = 7 if self.j.cdr else 0
        self.fail((left < 0) | (left > slack), f"{int(left.max())} unread bytes left over")


_MIX = np.uint64(0x100000001B3)  # FNV-1a 64-bit prime


def unique_rows(raw: U8) -> tuple[I64, I64]:
    """Distinct rows of a uint8[n, w] array: (index of one row per distinct value, inverse).

    Rows are hashed to uint64 (FNV-style over 8-byte words) and the hashes de-duplicated with a
    plain integer sort; equality with the representative row is then verified, and only on a
    hash collision does it fall back to sorting the rows as bytes (slow void comparisons)."""
    n, w = raw.shape
    words = np.zeros((n, (w + 7) // 8 * 8), np.uint8)
    words[:, :w] = raw
    h = np.full(n, np.uint64(0xCBF29CE484222325))
    for col in words.view("<u8").T:
        h = (h ^ col) * _MIX
    _, first, inv = np.unique(h, return_index=True, return_inverse=True)
    inv = inv.ravel()
    if (raw == raw[first[inv]]).all():
        return first.astype(np.int64), inv.astype(np.int64)
    _, first, inv = np.unique(
        np.ascontiguousarray(raw).view(f"V{w}").ravel(), return_index=True, return_inverse=True
    )
    return first.astype(np.int64), inv.ravel().astype(np.int64)


def string_codes(j: Joined, start: I64, length: I64, what: str) -> tuple[list[str], I64]:
    """Decode strings given by absolute (start, length) pairs as (distinct values, code per
    string). Vectorized per distinct length: equal-length strings are gathered into one
    fixed-width array and de-duplicated, so a column like frame_id costs a few numpy calls and
    one ``decode`` per distinct value."""
    names: list[str] = [""]
    codes = np.zeros(len(start), dtype=np.int64)
    for n in np.unique(length).tolist():
        if n == 0:
            continue
        sel = np.flatnonzero(length == n)
        raw = j.buf[start[sel][:, None] + np.arange(n)]
        first, inv = unique_rows(raw)
        try:
            texts = [raw[i].tobytes().decode("utf-8") for i in first.tolist()]
        except UnicodeDecodeError as exc:
            raise MessageDecodeError(f"cannot decode {what}: a string is not UTF-8") from exc
        codes[sel] = len(names) + inv
        names.extend(texts)
    return names, codes


def hashed_strings(j: Joined, start: I64, length: I64) -> I64:
    """:func:`formats.detections.frame.hash_id` of each (start, length) string, hashing each
    distinct value once (grouped by length, de-duplicated with ``np.unique``); empty -> -1."""
    from formats.detections.frame import hash_id

    out = np.full(len(start), -1, dtype=np.int64)
    for n in np.unique(length).tolist():
        if n == 0:
            continue
        sel = np.flatnonzero(length == n)
        raw = j.buf[start[sel][:, None] + np.arange(n)]
        first, inv = unique_rows(raw)
        hashes = np.array([hash_id(raw[i].tobytes()) for i in first.tolist()], dtype=np.int64)
        out[sel] = hashes[inv]
    return out


def equals_any(
    j: Joined, start: I64, length: I64, targets: tuple[str, ...]
) -> npt.NDArray[np.bool_]:
    """Whether each (start, length) string equals one of ``targets`` (vectorized)."""
    match = np.zeros(len(start), dtype=bool)
    for t in targets:
        tb = np.frombuffer(t.encode("utf-8"), dtype=np.uint8)
        sel = np.flatnonzero(length == len(tb))
        if len(sel) == 0:
            continue
        raw = j.buf[start[sel][:, None] + np.arange(len(tb))]
        match[sel[(raw == tb).all(axis=1)]] = True
    return match
