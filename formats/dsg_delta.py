"""Reading a live Hydra stream's scene graphs by what changed since the last one.

Why: a live Hydra sends its whole scene graph every second, and between two of them its
backend optimisation moves a few dozen places by millimetres and stamps them; the rest of the
1.9 MB payload of a 5,000-place graph is the same bytes. :func:`formats.dsg_binary.read_graph`
reads every record again (~10 ms); :class:`GraphReader` compares the payload with the last one
it read (one vectorised comparison) and, when every byte that differs lies inside node
records, reads only those records again and keeps every other value of the last graph.

**Exact, or not used.** A node record is read from its own bytes only, and the records are
consecutive (one ends where the next begins). So when the payload has the last one's length,
the bytes before the first node and after the last are unchanged, and every re-read record
reads as a record (its fixed head bytes, its attribute fields, its metadata JSON) and ends
exactly where it ended before, the whole payload parses into the same chain of records, and
:func:`read_graph` would return the last graph's values with those records' values replaced:
that is what is returned. A record that changed only in value bytes of its leading
fixed-size fields (a position, an update stamp, an agent's pose: neither a tag nor a length
among them) is not even parsed again: its tags and lengths are where they were, so it reads
field for field as before, and its new position and stamp are read in place. Anything
else — another length, a change in the layer table, the edges or the mesh, a record that
grew, shrank or no longer reads, a node id repeated — reads the payload whole
(``tests/formats/test_dsg_delta.py`` compares both on edited graphs).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from aion_cli.formats.dsg_binary import (
    F64,
    I64,
    U8,
    BinaryGraph,
    Bool,
    _metadata_ok,
    heads_ok,
    node_records,
    read_graph,
)
from aion_cli.formats.dsg_binary_fields import value_bytes, words


class GraphReader:
    """:func:`read_graph` for a stream of payloads, re-reading only the node records that
    changed since the last payload (module docstring). ``delta_reads`` counts the payloads
    read that way, ``whole_reads`` those read in full (the first, and every other change);
    ``labels`` keeps the stream's layer labels for :func:`formats.dsg_fast.fast_navigation`."""

    def __init__(self) -> None:
        from aion_cli.formats.dsg_fast import LabelMemo  # dsg_fast imports this module's type

        self._last: BinaryGraph | None = None
        self.labels = LabelMemo()
        """The labels of the stream's layers (:class:`formats.dsg_fast.LabelMemo`)."""
        self.values_only = False
        """Whether the last payload read changed node positions and stamps only (the same
        nodes, layers, kinds, names and frontier flags as the payload before it)."""
        self.navigation: Any = None
        """The snapshot made from the last payload and how (``formats.dsg_fast`` keeps it
        here, to move its nodes when the next payload changed values only)."""
        self.delta_reads = 0
        self.whole_reads = 0
        self.records_in_place = 0
        """Changed node records whose new values were read in place (not parsed again)."""
        self.records_parsed = 0
        """Changed node records parsed again by the reads by changes."""

    def read(self, payload: bytes | bytearray | memoryview | U8) -> BinaryGraph | None:
        """The graph of ``payload`` as :func:`read_graph` reads it (None: not one the numpy
        reader vouches for). The payload's bytes must stay unchanged while they are the last
        ones read (the graph views them, as :func:`read_graph`'s does)."""
        buf = np.frombuffer(payload, dtype=np.uint8)
        changed = _changed_records(buf, self._last) if self._last is not None else None
        graph: BinaryGraph | None
        if changed is not None:
            self.delta_reads += 1
            graph, self.values_only, in_place, parsed = changed
            self.records_in_place += in_place
            self.records_parsed += parsed
        else:
            graph = read_graph(buf)
            self.whole_reads += 1
            self.values_only = False
        self._last = graph
        return graph


def _changed_records(
    buf: U8, last: BinaryGraph
) -> tuple[BinaryGraph, bool, int, int] | None:
    """``buf``'s graph from ``last`` and the node records whose bytes differ, whether only
    positions and stamps changed (:func:`_values_only`), and how many changed records were
    read in place and how many parsed again; None when the payload must be read whole (see
    the module docstring).

    A record whose differing bytes are all value bytes of its leading fixed-size fields
    (:func:`formats.dsg_binary_fields.value_bytes`: a place moved and stamped, an agent's
    pose) has every tag, length and string where it was, so it reads field for field as it
    read before: its new position and stamp are read where they lie, without parsing it
    again. The other changed records are parsed again."""
    old = last.data
    starts, ends = last.node_start, last.node_end
    if len(buf) != len(old) or len(starts) == 0:
        return None
    changed = _differing_bytes(buf, old)
    if changed is None:
        return dataclasses.replace(last, data=buf), True, 0, 0
    if changed[0] < starts[0] or changed[-1] >= ends[-1]:
        return None  # the layer table, the edges or the mesh changed
    record = np.searchsorted(starts, changed, side="right") - 1  # ascending, as ``changed``
    in_place = _value_changes(changed - last.node_body[record], last.kind[record], last.kinds)
    first = np.ones(len(record), dtype=bool)
    first[1:] = record[1:] != record[:-1]
    touched = record[first]
    whole = np.logical_and.reduceat(in_place, np.flatnonzero(first))  # every byte in place
    parsed, moved = touched[~whole], touched[whole]
    xyz, stamp = last.xyz.copy(), last.stamp_ns.copy()
    _read_values(buf, last, moved, xyz, stamp)
    graph = dataclasses.replace(last, data=buf, xyz=xyz, stamp_ns=stamp)
    if parsed.size == 0:
        return graph, True, moved.size, 0
    again = _parsed_again(buf, graph, last, parsed)
    return None if again is None else (*again, moved.size, parsed.size)


def _differing_bytes(buf: U8, old: U8) -> I64 | None:
    """Every byte at which two payloads of one length differ, ascending (None: equal): the
    payloads compared 8 bytes at a time (8x fewer elements than bytes), then the bytes of the
    words that differ; the bytes before the first word and the tail that is no whole word
    byte by byte.

    The words start at the first 8-byte boundary of both payloads when they share one (a
    payload sliced out of a decompressed chunk seldom starts on one: the stream's 1.9 MB
    payloads start 4 bytes past it), so numpy compares aligned words: a quarter less time
    than the same comparison of unaligned words (0.30 against 0.41 ms per 5,000-place
    payload, issue 15)."""
    n = len(buf)
    lead = -buf.ctypes.data % 8
    if lead != -old.ctypes.data % 8:
        lead = 0  # no common boundary: one of them is unaligned whatever the start
    lead = min(lead, n)
    whole = lead + (n - lead) // 8 * 8
    head = np.flatnonzero(buf[:lead] != old[:lead])
    words = np.flatnonzero(buf[lead:whole].view(np.uint64) != old[lead:whole].view(np.uint64))
    at = (words[:, None] * 8 + (lead + np.arange(8))).reshape(-1)
    tail = np.flatnonzero(buf[whole:] != old[whole:]) + whole
    out: I64 = np.concatenate([head, at[buf[at] != old[at]], tail]).astype(np.int64)
    return out if out.size else None


def _value_changes(offset: I64, kind: I64, kinds: list[str]) -> Bool:
    """Per changed byte (``offset`` from its record's attribute fields, ``kind`` its
    record's type): whether it is a value byte of the record's leading fixed-size fields."""
    out = np.zeros(len(offset), dtype=bool)
    for k in np.flatnonzero(np.bincount(kind)).tolist():
        layout = value_bytes(kinds[k]) if 0 <= k < len(kinds) else None
        if layout is None:
            continue
        rows = kind == k
        o = offset[rows]
        inside = (o >= 0) & (o < layout.size)
        out[rows] = inside & layout.values[np.where(inside, o, 0)]
    return out


def _read_values(buf: U8, last: BinaryGraph, rows: I64, xyz: F64, stamp: I64) -> None:
    """The captured values (position, an agent's stamp) of records ``rows``, whose changes
    all lie in value bytes (:func:`_value_changes`), read where they lie into ``xyz`` and
    ``stamp``."""
    if rows.size == 0:
        return
    kind = last.kind[rows]
    for k in np.flatnonzero(np.bincount(kind)).tolist():
        at = rows[kind == k]
        layout = value_bytes(last.kinds[k])
        assert layout is not None  # (only records of such a type change in place)
        body = last.node_body[at]
        for name, offset, dtype in layout.captures:
            value = words(buf, dtype)[body + offset]
            if name in _AXES:
                xyz[at, _AXES[name]] = value
            elif name == "stamp_ns":
                stamp[at] = value
            else:  # a capture a snapshot does not use here would need a place to go
                raise AssertionError(f"unexpected capture {name}")


_AXES = {"x": 0, "y": 1, "z": 2}


def _parsed_again(
    buf: U8, graph: BinaryGraph, last: BinaryGraph, touched: I64
) -> tuple[BinaryGraph, bool] | None:
    """``graph`` (``last`` with the values read in place) with the records ``touched``
    parsed again from ``buf``; None where they no longer read as the same chain of records
    (the payload is then read whole)."""
    at = last.node_start[touched]
    if not heads_ok(buf, at):
        return None
    cols, record_ends, ok, (meta_start, meta_len) = node_records(buf, at, last.kinds)
    if not ok.all() or not np.array_equal(record_ends, last.node_end[touched]):
        return None
    if not _metadata_ok(buf, meta_start, meta_len):
        return None
    ids = last.ids.copy()
    ids[touched] = cols["ids"]
    if not np.array_equal(ids[touched], last.ids[touched]):
        ordered = np.sort(ids)
        if (ordered[1:] == ordered[:-1]).any():
            return None  # read whole: read_graph decides what a repeated id means
    xyz = graph.xyz.copy()
    xyz[touched] = np.column_stack([cols["x"], cols["y"], cols["z"]])
    values_only = _values_only(buf, last, touched, cols)
    out = dataclasses.replace(
        graph,
        layer=_replaced(last.layer, touched, cols["layer"]),
        partition=_replaced(last.partition, touched, cols["partition"]),
        ids=ids,
        kind=_replaced(last.kind, touched, cols["kind"]),
        xyz=xyz,
        name_start=_replaced(last.name_start, touched, cols["name_start"]),
        name_len=_replaced(last.name_len, touched, cols["name_len"]),
        real_place=_replaced(last.real_place, touched, cols["real_place"]),
        stamp_ns=_replaced(graph.stamp_ns, touched, cols["stamp_ns"]),
        node_body=_replaced(last.node_body, touched, meta_start + meta_len),
    )
    return out, values_only


_SAME = ("layer", "partition", "ids", "kind", "name_start", "name_len", "real_place")
"""The node values a snapshot's structure depends on (all but positions and stamps)."""


def _values_only(buf: U8, last: BinaryGraph, touched: I64, cols: dict[str, Any]) -> bool:
    """Whether the re-read records ``touched`` kept every value but their positions and
    stamps: the same key, id, kind, frontier flag and name (its bytes too)."""
    for name in _SAME:
        if not np.array_equal(
            np.asarray(cols[name]).astype(getattr(last, name).dtype), getattr(last, name)[touched]
        ):
            return False
    named = touched[last.name_len[touched] > 0]
    old = last.data
    for start, length in zip(
        last.name_start[named].tolist(), last.name_len[named].tolist(), strict=True
    ):
        if not np.array_equal(buf[start : start + length], old[start : start + length]):
            return False
    return True


def _replaced(values: np.ndarray, rows: np.ndarray, new: np.ndarray) -> np.ndarray:
    """A copy of ``values`` with ``rows`` set to ``new`` (cast to ``values``' dtype)."""
    out = values.copy()
    out[rows] = new
    return out
