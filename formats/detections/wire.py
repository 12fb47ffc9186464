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

Arrays of variable-size elements (a person with a name, a string[]) are read by :func:`walk`:
element k of every message at once, and after each element a *speculative* read of all the
following elements of the same message, assumed to have the same size. The speculation runs on
"soft" cursors (a failed check marks the cursor bad instead of raising); the elements it got
right are kept, the first that differs ends the run. An array of a million equal persons is
then 8 vectorised rounds instead of a million (the guesses grow eightfold while they are
right), and the Python loop runs once per run of equally sized elements, never once per
element. :data:`MAX_WALK_ROUNDS` bounds the loop for an array whose every element differs in
size from the one before: such a message is a :class:`MessageDecodeError` (the adapter then
tries the rosbags decoder, up to its size limit; else it is a counted decode failure), never
minutes of work.

The joined buffer (:class:`Joined`, :func:`join_payloads`) and its fixed-width gathers
(:func:`block`, :func:`gather`, :func:`gather_f64`) live in :mod:`formats.detections.wire_buffer`
and are re-exported here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np
import numpy.typing as npt

from aion_cli.errors import MessageDecodeError
from aion_cli.formats.detections.wire_buffer import (
    CDR_LE,
    F64,
    I64,
    U8,
    Joined,
    block,
    gather,
    gather_f64,
    join_payloads,
)


class Cursors:
    """Read positions advancing in lock-step over many messages or elements.

    ``base`` is the alignment origin (payload start) of each cursor, ``pos`` the current
    absolute position, ``end`` the absolute end of its message, ``msg`` its message index (for
    error messages). All reads check ``pos + size <= end`` first."""

    def __init__(
        self,
        j: Joined,
        base: I64,
        pos: I64,
        end: I64,
        msg: I64,
        what: str,
        bad: npt.NDArray[np.bool_] | None = None,
    ) -> None:
        self.j = j
        self.base = base
        self.pos = pos
        self.end = end
        self.msg = msg
        self.what = what
        #: None: strict cursors (a failed check raises). An array: "soft" cursors of a
        #: speculative read, where a failed check sets the cursor's flag instead, parks it at
        #: its message start (so later reads stay inside the buffer) and zeroes the lengths
        #: and counts it reads (so nothing is sized from garbage).
        self.bad = bad

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
            self.what, None if self.bad is None else self.bad[mask].copy(),
        )

    def merge(self, mask: npt.NDArray[np.bool_], sub: Cursors) -> None:
        self.pos[mask] = sub.pos
        if self.bad is not None and sub.bad is not None:
            self.bad[mask] = sub.bad

    def repeat(self, counts: I64, first: I64, stride: int | I64) -> Cursors:
        """One cursor per array element: cursor i is repeated ``counts[i]`` times, element k
        starting at ``first[i] + k * stride`` (fixed-size elements; ``stride`` may differ per
        cursor)."""
        total = int(counts.sum())
        owner = np.repeat(np.arange(len(counts)), counts)
        k = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
        step = stride if isinstance(stride, int) else np.asarray(stride, np.int64)[owner]
        pos = first[owner] + k * step
        return Cursors(
            self.j, self.base[owner], pos, self.end[owner], self.msg[owner], self.what,
            None if self.bad is None else self.bad[owner],
        )

    def soft(self) -> Cursors:
        """Soft copies of these cursors (see ``bad``), none of them bad yet."""
        return Cursors(
            self.j, self.base, self.pos.copy(), self.end, self.msg, self.what,
            np.zeros(len(self.pos), dtype=bool),
        )

    def _ok(self, n: I64) -> I64:
        """``n`` where the cursor is fine, 0 where it is bad (soft cursors)."""
        return n if self.bad is None else np.where(self.bad, 0, n)

    # --- checks -----------------------------------------------------------------------------
    def fail(self, bad: npt.NDArray[np.bool_], problem: str) -> None:
        """Raise for the first cursor in ``bad`` (if any); soft cursors are flagged and parked
        at their message start instead."""
        if self.bad is not None:
            if bad.any():
                self.bad |= bad
                self.pos = np.where(self.bad, self.base, self.pos)
            return
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
            self.pos = self.aligned(w)

    def aligned(self, w: int, first: I64 | None = None) -> I64:
        """Positions aligned to ``w`` without moving the cursors."""
        p = self.pos if first is None else first
        if not self.j.cdr or w == 1:
            return p
        if w & (w - 1):  # not a power of two (CDR alignments are 2, 4 and 8)
            return self.base + ((p - self.base + (w - 1)) // w) * w
        return self.base + ((p - self.base + (w - 1)) & -w)

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
        n = self._ok(n)
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
        return self._ok(n)

    def skip_strings(self, counts: I64) -> None:
        """Skip ``counts[i]`` strings at each cursor (a string[] body), with :func:`walk`."""
        walk(self, counts, _skip_string)

    def skip_bytes_seq(self, elem: int) -> None:
        """Skip a primitive sequence of ``elem``-byte items (e.g. uint8[] data)."""
        n = self.count(elem)
        has = n > 0
        if has.any():
            self.pos = np.where(has, self.aligned(elem), self.pos)
        self.need(n * elem)
        self.pos = self.pos + self._ok(n) * elem

    def check_consumed(self) -> None:
        """The message must end here: exactly for ROS 1, within CDR's trailing padding (< 8
        bytes) for CDR. Catches a different layout of the same type name."""
        left = self.end - self.pos
        slack = 7 if self.j.cdr else 0
        self.fail((left < 0) | (left > slack), f"{int(left.max())} unread bytes left over")


def _skip_string(s: Cursors, rows: I64) -> None:
    s.string()


#: Most rounds :func:`walk` runs over one decoded buffer (all its arrays, nested ones
#: included): each round reads at least one element plus the run of equally sized elements
#: after it, so only messages whose elements change size this often are refused (a
#: MessageDecodeError: the adapter then decodes the batch's messages one by one, each with
#: this budget). Costs at most ~1 s; real messages need a few dozen rounds per batch.
MAX_WALK_ROUNDS = 10_000
#: Most rounds of a walk on soft cursors (an array nested in a speculatively read element,
#: maybe read at a wrong place from garbage): past it the guess is dropped, and the element
#: is read again for real later. These rounds are not taken from MAX_WALK_ROUNDS.
_SOFT_ROUNDS = 16
#: Fewest elements a round reads speculatively after a run broke (then twice the last run,
#: and eight times more after every guess that was right throughout).
_MIN_GUESS = 8
#: Elements read speculatively after the first element of an array.
_FIRST_GUESS = 64
#: Upper bound of one speculative read (elements of one message).
_MAX_GUESS = 1 << 22


Step = Callable[[Cursors, I64], None]
"""Reads one element per cursor and stores it at the given row indices (message-major row
numbering: row of element k of cursor i = sum of the counts before i, plus k). A step may only
*assign* its rows (never accumulate into shared state): :func:`walk` also runs it on wrong
guesses, whose rows it then overwrites."""


def walk(c: Cursors, counts: I64, step: Step, max_rounds: int | None = None) -> None:
    """Read ``counts[i]`` variable-size elements at every cursor of ``c`` with ``step``,
    vectorised over cursors *and* over runs of equally sized elements.

    Each round reads the next element of every cursor exactly (strict or soft, as ``c``),
    then reads the following elements speculatively, as if each had the size of that one:
    soft cursors at ``pos + j * size``. A speculative element is right when every one before
    it had that size and it decoded without a failed check; the right ones are kept (their
    rows are final), and the first one of another size is kept too (it started at the right
    place), ending the run. Rows written for the wrong guesses are overwritten when their
    elements are read for real. ``c`` ends after the last element. More than ``max_rounds``
    rounds over the buffer (``c.j.walk_rounds``, nested walks included; default
    :data:`MAX_WALK_ROUNDS`) is a failed check (:class:`MessageDecodeError`); a walk of soft
    cursors (nested in a guess) stops after :data:`_SOFT_ROUNDS` rounds, dropping the guess."""
    limit = MAX_WALK_ROUNDS if max_rounds is None else max_rounds
    counts = np.asarray(counts, np.int64)
    row0 = np.cumsum(counts) - counts
    k = np.zeros(len(counts), np.int64)
    guess = np.full(len(counts), _FIRST_GUESS, np.int64)
    soft_rounds = 0
    while True:
        if c.bad is not None:  # soft: a cursor that failed stops reading
            k = np.where(c.bad, counts, k)
        active = k < counts
        if not active.any():
            return
        if c.bad is None:
            c.j.walk_rounds += 1
            over = c.j.walk_rounds > limit
        else:  # a speculative read: give up the guess rather than spend rounds on it
            soft_rounds += 1
            over = soft_rounds > _SOFT_ROUNDS
        if over:
            c.fail(
                active,
                f"more than {limit:,} runs of differently sized elements in one array "
                "(aion's limit)",
            )
            return
        whole = bool(active.all())
        sub = c if whole else c.subset(active)
        ka = k if whole else k[active]
        base_rows = row0 if whole else row0[active]
        before = sub.pos.copy()
        step(sub, base_rows + ka)
        size = sub.pos - before
        ka = ka + 1
        g = np.minimum(counts[active] - ka, guess[active])
        g = np.where(size > 0, g, 0)
        if sub.bad is not None:
            g = np.where(sub.bad, 0, g)
        taken = np.zeros(len(g), np.int64)
        if g.any():
            taken = _speculate(sub, g, size, base_rows + ka, step)
        k[active] = ka + taken
        guess[active] = np.where(
            taken == g, np.minimum(8 * np.maximum(g, 1), _MAX_GUESS),
            np.maximum(_MIN_GUESS, 2 * taken),
        )
        if not whole:
            c.merge(active, sub)


def _speculate(sub: Cursors, g: I64, size: I64, first_rows: I64, step: Step) -> I64:
    """Read ``g[i]`` elements after cursor i as if each were ``size[i]`` bytes long; move the
    cursors past the elements that were right and return how many those were."""
    spec = sub.repeat(g, sub.pos, size).soft()
    within = np.arange(len(spec)) - np.repeat(np.cumsum(g) - g, g)
    start = spec.pos.copy()
    step(spec, np.repeat(first_rows, g) + within)
    assert spec.bad is not None
    fine = ~spec.bad
    same = fine & (spec.pos - start == np.repeat(size, g))
    # per cursor: the leading run of right-sized elements, plus the next one if it decoded
    group = np.repeat(np.arange(len(g)), g)
    broken = np.flatnonzero(~same)
    first_break = np.full(len(g), -1, np.int64)
    if len(broken):
        # the first break of each group: broken is sorted, so the first index per group wins
        grp = group[broken]
        keep = np.ones(len(broken), dtype=bool)
        keep[1:] = grp[1:] != grp[:-1]
        first_break[grp[keep]] = within[broken[keep]]
    run = np.where(first_break < 0, g, first_break)
    offset0 = np.cumsum(g) - g
    nxt = offset0 + run  # index (in spec) of the element that broke the run
    has_next = run < g
    next_fine = np.zeros(len(g), dtype=bool)
    next_fine[has_next] = fine[nxt[has_next]]
    taken = run + next_fine
    last = offset0 + taken - 1
    moved = taken > 0
    sub.pos = np.where(moved, spec.pos[np.where(moved, last, 0)], sub.pos)
    return taken


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


def _distinct_by_length(j: Joined, start: I64, length: I64) -> Iterator[tuple[I64, U8, I64, I64]]:
    """Per distinct non-empty length: (indices, bytes as rows, :func:`unique_rows` of them)."""
    for n in np.unique(length).tolist():
        if n == 0:
            continue
        sel = np.flatnonzero(length == n)
        raw = j.buf[start[sel][:, None] + np.arange(n)]
        first, inv = unique_rows(raw)
        yield sel, raw, first, inv


def string_codes(
    j: Joined,
    start: I64,
    length: I64,
    what: str,
    invalid: npt.NDArray[np.bool_] | None = None,
) -> tuple[list[str], I64]:
    """Decode strings given by absolute (start, length) pairs as (distinct values, code per
    string). Vectorized per distinct length: equal-length strings are gathered into one
    fixed-width array and de-duplicated, so a column like frame_id costs a few numpy calls and
    one ``decode`` per distinct value.

    A string that is not UTF-8 raises :class:`MessageDecodeError`, or, when ``invalid`` (a
    bool array as long as ``start``) is given, is flagged there and gets code 0 (``""``)."""
    names: list[str] = [""]
    codes = np.zeros(len(start), dtype=np.int64)
    for sel, raw, first, inv in _distinct_by_length(j, start, length):
        texts: list[str] = []
        for k, i in enumerate(first.tolist()):
            try:
                texts.append(raw[i].tobytes().decode("utf-8"))
            except UnicodeDecodeError as exc:
                if invalid is None:
                    raise MessageDecodeError(
                        f"cannot decode {what}: a string is not UTF-8"
                    ) from exc
                texts.append("")
                invalid[sel[inv == k]] = True
        codes[sel] = len(names) + inv
        names.extend(texts)
    return names, codes


def hashed_strings(j: Joined, start: I64, length: I64) -> I64:
    """:func:`formats.detections.frame.hash_id` of each (start, length) string, hashing each
    distinct value once (grouped by length, de-duplicated with ``np.unique``); empty -> -1."""
    from aion_cli.formats.detections.frame import hash_id

    out = np.full(len(start), -1, dtype=np.int64)
    for sel, raw, first, inv in _distinct_by_length(j, start, length):
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


__all__ = [
    "CDR_LE",
    "F64",
    "I64",
    "MAX_WALK_ROUNDS",
    "U8",
    "Cursors",
    "Joined",
    "Step",
    "block",
    "equals_any",
    "gather",
    "gather_f64",
    "hashed_strings",
    "join_payloads",
    "string_codes",
    "unique_rows",
    "walk",
]
