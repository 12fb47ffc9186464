"""Fast TF decoding: ``tf2_msgs/TFMessage`` (ROS 2 CDR) and ``tf/tfMessage`` (ROS 1) read with
numpy straight from their serialized bytes, many messages per call.

A TFMessage is a sequence of ``geometry_msgs/TransformStamped``::

    header (ROS 1: uint32 seq, sec, nsec | ROS 2: int32 sec, uint32 nanosec)
           string frame_id
    string child_frame_id
    float64[3] translation, float64[4] rotation (x, y, z, w)

The two frame strings make every transform's size variable, so transforms are walked element
index by element index with :class:`formats.detections.wire.Cursors`, vectorized over all
messages at once: the Python loop runs ``max(transforms per message)`` times (2 for a typical
robot), not once per transform or per message. Every read is bounds-checked and each message
must be consumed exactly (ROS 1) or up to CDR's trailing padding, so a truncated, garbage or
differently laid out payload raises :class:`MessageDecodeError` instead of yielding values; the
caller then falls back to the generic (rosbags) decoder.

Stamps are ``sec * 10**9 + nsec`` with ``sec`` read as uint32 in ROS 1 (``time``: to 2106)
and int32 in ROS 2 (``builtin_interfaces/Time``), exactly like the generic decoder this
replaces (rosbags with :func:`formats.msgdefs.base_typestore`) reads them.

Frame names are de-duplicated before decoding (a log has a handful of distinct frames) and
normalised like :func:`formats.tf.normalize_frame` (surrounding whitespace and leading ``/``
stripped).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.errors import MessageDecodeError
from aion_cli.formats.detections.wire import Cursors, block, gather_f64, join_payloads, string_codes
from aion_cli.formats.raw import RawMessage
from aion_cli.formats.tf import normalize_frame

I64 = npt.NDArray[np.int64]
F64 = npt.NDArray[np.float64]
BoolA = npt.NDArray[np.bool_]

#: Message types with the TFMessage layout (normalised ``pkg/msg/Type`` spelling).
TF_TYPES = frozenset({"tf2_msgs/msg/TFMessage", "tf/msg/tfMessage"})

_HDR1 = np.dtype([("seq", "<u4"), ("sec", "<u4"), ("nsec", "<u4"), ("len", "<u4")])
_HDR2 = np.dtype([("sec", "<i4"), ("nsec", "<u4"), ("len", "<u4")])


@dataclass(frozen=True)
class TfArrays:
    """n decoded transforms ``parent_T_child`` in message order (then transform order).

    ``names`` holds the distinct normalised frame names (``names[0] == ""``); ``parent_code`` /
    ``child_code`` index it. ``msg_index[i]`` is the message (position in the input) that row i
    came from; ``counts[m]`` is the number of transforms of message m.
    """

    names: list[str]
    parent_code: I64
    child_code: I64
    t_ns: I64
    translation: F64
    quat_xyzw: F64
    msg_index: I64
    counts: I64

    def __len__(self) -> int:
        return len(self.t_ns)

    @property
    def parent(self) -> list[str]:
        """Parent frame name per row."""
        names = self.names
        return [names[c] for c in self.parent_code.tolist()]

    @property
    def child(self) -> list[str]:
        """Child frame name per row."""
        names = self.names
        return [names[c] for c in self.child_code.tolist()]

    def usable(self) -> BoolA:
        """Rows whose frames are both non-empty and different (what a TF buffer can take)."""
        return (
            (self.parent_code != 0) & (self.child_code != 0) & (self.parent_code != self.child_code)
        )

    def by_edge(self) -> Iterator[tuple[str, str, TfArrays]]:
        """``(parent, child, rows)`` per distinct frame pair, in order of first appearance, rows
        in their original order: one :meth:`formats.tf.TfBuffer.add_transforms` call per edge
        with plain ``str`` frames takes its ungrouped fast path (no per-row Python work)."""
        if len(self) == 0:
            return
        pair = self.parent_code * len(self.names) + self.child_code
        _, first, inv = np.unique(pair, return_index=True, return_inverse=True)
        inv = inv.ravel()
        if len(first) == 1:
            yield self.names[int(self.parent_code[0])], self.names[int(self.child_code[0])], self
            return
        order = np.argsort(inv, kind="stable")
        bounds = np.searchsorted(inv[order], np.arange(len(first) + 1))
        for g in np.argsort(first, kind="stable").tolist():
            rows = order[bounds[g] : bounds[g + 1]]
            i = int(rows[0])
            sub = self.select(rows)
            yield self.names[int(self.parent_code[i])], self.names[int(self.child_code[i])], sub

    def select(self, rows: I64 | BoolA) -> TfArrays:
        """A subset of rows (``counts`` and ``msg_index`` are kept as given)."""
        return TfArrays(
            self.names,
            self.parent_code[rows],
            self.child_code[rows],
            self.t_ns[rows],
            self.translation[rows],
            self.quat_xyzw[rows],
            self.msg_index[rows],
            self.counts,
        )


def _empty(n_messages: int) -> TfArrays:
    z = np.zeros(0, dtype=np.int64)
    return TfArrays(
        [""], z, z.copy(), z.copy(), np.zeros((0, 3)), np.zeros((0, 4)), z.copy(),
        np.zeros(n_messages, dtype=np.int64),
    )  # fmt: skip


def _string_body(c: Cursors, n: I64) -> tuple[I64, I64]:
    """Skip string bodies of ``n`` bytes (length field already read): (start, text length).

    CDR strings must hold their NUL terminator (length >= 1, last byte 0), as rosbags checks."""
    c.need(n)
    start = c.pos
    c.pos = c.pos + n
    if not c.j.cdr:
        return start, n
    bad = (n < 1) | (c.j.buf[start + np.maximum(n, 1) - 1] != 0)
    if bad.any():
        c.pos = start - 4
        c.fail(bad, "string without its NUL terminator")
    return start, n - 1


def _decode_group(messages: Sequence[RawMessage], cdr: bool) -> TfArrays:
    """Decode messages that all share one encoding."""
    j = join_payloads(messages, cdr)
    c = Cursors.over_messages(j, "TFMessage")
    # a TransformStamped takes at least 4+4+4+4+56 bytes (ROS 2 header and empty strings)
    counts = c.count(72)
    total = int(counts.sum())
    n_max = int(counts.max()) if len(counts) else 0
    # row of element k of message m: first[m] + k (message order, then transform order)
    first = np.cumsum(counts) - counts
    hdr = _HDR2 if cdr else _HDR1
    sec = np.empty(total, dtype=np.int64)
    nsec = np.empty(total, dtype=np.int64)
    f_start = np.empty(total, dtype=np.int64)
    f_len = np.empty(total, dtype=np.int64)
    c_start = np.empty(total, dtype=np.int64)
    c_len = np.empty(total, dtype=np.int64)
    values = np.empty((total, 7), dtype=np.float64)
    msgs = np.arange(len(counts))
    for k in range(n_max):
        mask = counts > k
        whole = bool(mask.all())
        sub = c if whole else c.subset(mask)
        rows = first[msgs if whole else msgs[mask]] + k
        # header stamp (+ ROS 1 seq) and the frame_id length: one fixed-size block
        sub.align(4)
        sub.need(hdr.itemsize)
        head = block(j, sub.pos, hdr.itemsize).view(hdr).ravel()
        sec[rows] = head["sec"]
        nsec[rows] = head["nsec"]
        sub.pos = sub.pos + hdr.itemsize
        f_start[rows], f_len[rows] = _string_body(sub, head["len"].astype(np.int64))
        c_start[rows], c_len[rows] = _string_body(sub, sub.u32())
        sub.align(8)
        sub.need(56)
        values[rows] = gather_f64(j, sub.pos, 7)
        sub.pos = sub.pos + 56
        if not whole:
            c.merge(mask, sub)
    c.check_consumed()
    names, codes = string_codes(
        j, np.concatenate([f_start, c_start]), np.concatenate([f_len, c_len]), "TF frame id"
    )
    norm = [normalize_frame(s) for s in names]
    distinct = sorted(set(norm) - {""})
    out_names = ["", *distinct]
    index = {s: i for i, s in enumerate(out_names)}
    remap = np.array([index[s] for s in norm], dtype=np.int64)
    codes = remap[codes]
    return TfArrays(
        out_names,
        codes[:total],
        codes[total:],
        sec * 1_000_000_000 + nsec,
        values[:, :3].copy(),
        values[:, 3:].copy(),
        np.repeat(np.arange(len(counts)), counts),
        counts,
    )


def decode_tf_messages(messages: Sequence[RawMessage]) -> TfArrays:
    """Decode many TFMessage payloads (any mix of ROS 2 CDR and ROS 1) into arrays.

    Rows come in input-message order, then transform order (what a TF buffer needs for "the
    last static transform wins" and for in-order appends). Raises :class:`MessageDecodeError`
    if any message is not a TFMessage, is truncated or garbage, or is big-endian CDR (which
    only the generic decoder reads): the caller decodes that batch generically.
    """
    n = len(messages)
    if n == 0:
        return _empty(0)
    for m in messages:
        if m.msgtype not in TF_TYPES:
            raise MessageDecodeError(f"{m.topic!r}: {m.msgtype} is not a TFMessage")
    cdr = np.fromiter((m.encoding == "cdr" for m in messages), dtype=bool, count=n)
    if cdr.all() or not cdr.any():
        return _decode_group(messages, bool(cdr[0]))
    parts = []
    for flag in (True, False):
        idx = np.flatnonzero(cdr == flag)
        part = _decode_group([messages[i] for i in idx.tolist()], flag)
        parts.append((idx, part))
    return _merge(parts, n)


def _merge(parts: list[tuple[I64, TfArrays]], n_messages: int) -> TfArrays:
    """Join decoded groups (``idx``: the group's messages in the input) back in input order."""
    names = sorted({s for _, p in parts for s in p.names} - {""})
    out_names = ["", *names]
    index = {s: i for i, s in enumerate(out_names)}
    counts = np.zeros(n_messages, dtype=np.int64)
    cols: dict[str, list[npt.NDArray[np.generic]]] = {
        k: [] for k in ("parent", "child", "t", "tr", "q", "msg")
    }
    for idx, p in parts:
        remap = np.array([index[s] for s in p.names], dtype=np.int64)
        counts[idx] = p.counts
        cols["parent"].append(remap[p.parent_code])
        cols["child"].append(remap[p.child_code])
        cols["t"].append(p.t_ns)
        cols["tr"].append(p.translation)
        cols["q"].append(p.quat_xyzw)
        cols["msg"].append(idx[p.msg_index])
    msg = np.concatenate(cols["msg"])
    order = np.argsort(msg, kind="stable")
    return TfArrays(
        out_names,
        np.concatenate(cols["parent"])[order],
        np.concatenate(cols["child"])[order],
        np.concatenate(cols["t"])[order],
        np.concatenate(cols["tr"])[order],
        np.concatenate(cols["q"])[order],
        msg[order],
        counts,
    )


def layout_matches(msgtype: str, encoding: str, definition: str, idl: bool = False) -> bool:
    """Whether a log's own ``definition`` of a TF type (``tf2_msgs/TFMessage`` or the old
    ``tf/tfMessage``) has the TFMessage layout this module decodes; an empty definition (the
    log embeds none) is taken as that layout. Anything else goes to the generic decoder, which
    reads the log's definition."""
    from aion_cli.formats import msg_layouts

    if msgtype not in TF_TYPES:
        return False
    ros_version = 1 if encoding == "ros1" else 2
    return msg_layouts.same_layout(
        definition, msgtype, ros_version, idl, reference="tf2_msgs/msg/TFMessage"
    )
