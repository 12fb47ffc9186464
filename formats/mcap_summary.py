"""An MCAP file's summary checked against its data section, before anything trusts it.

:func:`check_summary` compares the summary (chunk indexes and statistics) with the data
section, walked record head by record head (:func:`formats.mcap_records.walk`) and with the
message index records that follow each chunk (a few bytes per channel and chunk, no chunk is
decompressed): chunks the summary does not index, channels a chunk index leaves out, counts
and times that disagree. :mod:`formats.mcap_source` reads through the summary only when it
agrees (:class:`SummaryCheck`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import IO, TYPE_CHECKING, Any

from aion_cli.engine.time_text import iso_utc
from aion_cli.formats.mcap_records import (
    CORRUPT,
    MESSAGE_HEAD,
    MESSAGE_PREFIX,
    OP_CHUNK,
    OP_MESSAGE,
    RECORD_HEAD,
    ChunkHead,
    RecordError,
    read_chunk_head,
    read_index_heads,
    walk,
)

if TYPE_CHECKING:
    from aion_cli.formats.limits import ReadLimits


@dataclass
class SummaryCheck:
    """What :func:`check_summary` found.

    ``problems``: ways in which the summary misses or misstates data (chunks or messages it
    does not index, channels a chunk index leaves out, statistics that disagree): reading
    through it would lose messages or report wrong figures, so the reader reads the data
    instead. ``bad_chunks``: chunk indexes whose chunk record cannot be read (offset -> why,
    prefixed :data:`CORRUPT`):
    those chunks alone are skipped. ``counts``: messages per channel of each chunk (by chunk
    offset) from its message index records. ``unsure``: the statistics count no message but
    some chunk without message indexes holds records (only reading it can tell).
    ``bare_messages``: Message records outside chunks. The MCAP specification allows them
    beside chunks, and chunk indexes cannot list them, so reading through the chunk indexes
    would miss them: the reader reads the data section instead, which is no fault of the
    file (not a problem, no warning).
    """

    problems: list[str] = field(default_factory=list)
    bad_chunks: dict[int, str] = field(default_factory=dict)
    counts: dict[int, dict[int, int]] = field(default_factory=dict)
    unsure: bool = False
    bare_messages: int = 0
    # chunks whose record states a wrong length but agrees with its index otherwise: read
    # with the index's length (offset -> chunk length); ``notes`` says so
    lengths: dict[int, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def check_summary(
    f: IO[bytes],
    size: int,
    chunk_indexes: list[Any],
    statistics: Any,
    topics: Mapping[int, str],
) -> SummaryCheck:
    """Compare an MCAP summary (``chunk_indexes``, ``statistics``: mcap library records) with
    the data section of the file ``f`` of ``size`` bytes; ``topics`` names channels in the
    messages. Walks the record heads from byte 8; where a damaged record stops the walk, it
    resumes at the next chunk an index points to (the unreadable chunk itself goes to
    ``bad_chunks``)."""
    check = SummaryCheck()
    by_offset = {c.chunk_start_offset: c for c in chunk_indexes}
    resume_points = sorted(by_offset)
    heads: dict[int, ChunkHead] = {}
    bare_messages = 0
    bare_times: list[int] = []
    pos = 8
    while True:
        try:
            for offset, opcode, length in walk(f, pos, size):
                if opcode == OP_CHUNK:
                    try:
                        heads[offset] = read_chunk_head(f, offset, size)
                    except ValueError as exc:
                        check.bad_chunks[offset] = f"{CORRUPT}unreadable chunk record: {exc}"
                        continue
                    counts = check.counts.setdefault(offset, {})
                    end = offset + RECORD_HEAD.size + length
                    for _, cid, n in read_index_heads(f, end, size):
                        counts[cid] = counts.get(cid, 0) + n
                elif opcode == OP_MESSAGE:
                    bare_messages += 1
                    if length >= MESSAGE_PREFIX:
                        f.seek(offset + RECORD_HEAD.size)
                        _, _, log_time = MESSAGE_HEAD.unpack(f.read(MESSAGE_HEAD.size))
                        bare_times.append(log_time)
            break
        except RecordError as exc:
            later = [p for p in resume_points if p > exc.offset]
            index = by_offset.get(exc.offset)
            if index is not None:
                head = _with_index_length(f, size, index)
                if head is None:
                    check.bad_chunks[exc.offset] = f"{CORRUPT}unreadable chunk record: {exc}"
                else:  # the length field alone is damaged: the index knows the length
                    heads[exc.offset] = head
                    check.lengths[exc.offset] = index.chunk_length
                    check.notes.append(
                        f"the record of the chunk at byte {exc.offset} states a wrong length "
                        f"({exc}); it is read with the length its chunk index gives"
                    )
            if not later:
                break
            pos = later[0]
    for offset, index in by_offset.items():
        if offset not in heads or offset in check.lengths:  # not walked: its message indexes
            first = offset + index.chunk_length
            last = min(size, first + index.message_index_length)
            counts = check.counts.setdefault(offset, {})
            for _, cid, n in read_index_heads(f, first, last):
                counts[cid] = counts.get(cid, 0) + n
    _compare(check, by_offset, heads, bare_messages, bare_times, statistics, topics)
    return check


def _with_index_length(f: IO[bytes], size: int, index: Any) -> ChunkHead | None:
    """The chunk record at ``index``'s offset read with the index's length, when every other
    field agrees with the index (only the record's length field is damaged); else None."""
    try:
        head = read_chunk_head(f, index.chunk_start_offset, size, index.chunk_length)
    except ValueError:
        return None
    same = (
        head.compression == index.compression
        and head.data_length == index.compressed_size
        and head.uncompressed_size == index.uncompressed_size
        and (head.start, head.end) == (index.message_start_time, index.message_end_time)
        and head.data_offset + head.data_length == index.chunk_start_offset + index.chunk_length
    )
    return head if same else None


def _compare(
    check: SummaryCheck,
    by_offset: dict[int, Any],
    heads: dict[int, ChunkHead],
    bare_messages: int,
    bare_times: list[int],
    statistics: Any,
    topics: Mapping[int, str],
) -> None:
    problems = check.problems
    unindexed = sorted(set(heads) - set(by_offset))
    if unindexed:
        problems.append(
            f"{len(unindexed)} chunk(s) are not in its chunk indexes (first at byte "
            f"{unindexed[0]})"
        )
    check.bare_messages = bare_messages
    for offset, index in sorted(by_offset.items()):
        head = heads.get(offset)
        if head is None:
            check.bad_chunks.setdefault(
                offset, f"{CORRUPT}no chunk record at the offset its index gives"
            )
            continue
        fields = [
            name
            for name, ours, theirs in (
                ("length", head.length, index.chunk_length),
                ("compression", head.compression, index.compression),
                ("compressed size", head.data_length, index.compressed_size),
                ("uncompressed size", head.uncompressed_size, index.uncompressed_size),
                ("start time", head.start, index.message_start_time),
                ("end time", head.end, index.message_end_time),
            )
            if ours != theirs
        ]
        if fields:
            problems.append(
                f"the chunk index of the chunk at byte {offset} disagrees with the chunk "
                f"record ({', '.join(fields)})"
            )
        counts = check.counts.get(offset, {})
        listed = index.message_index_offsets or {}
        left_out = {cid: n for cid, n in counts.items() if n and listed and cid not in listed}
        for cid, n in sorted(left_out.items()):
            problems.append(
                f"the chunk index of the chunk at byte {offset} leaves out channel {cid} "
                f"({topics.get(cid, '?')}), which has {n:,} message(s) there"
            )
    if statistics is None:
        return
    _compare_statistics(check, by_offset, heads, bare_messages, bare_times, statistics)


def _compare_statistics(
    check: SummaryCheck,
    by_offset: dict[int, Any],
    heads: dict[int, ChunkHead],
    bare_messages: int,
    bare_times: list[int],
    statistics: Any,
) -> None:
    problems = check.problems
    stated = dict(statistics.channel_message_counts or {})
    if sum(stated.values()) != statistics.message_count:
        problems.append(
            f"its statistics count {statistics.message_count:,} messages in all but "
            f"{sum(stated.values()):,} over the channels"
        )
    indexed: dict[int, int] = {}
    every_chunk_indexed = True
    starts, ends = list(bare_times), list(bare_times)
    zero_chunk = False
    # (offset, start, end, uncompressed size) of every chunk: its record's where readable,
    # its index's where not (what cannot be checked is taken as the index says)
    spans = [(o, h.start, h.end, h.uncompressed_size) for o, h in heads.items()]
    spans += [
        (o, c.message_start_time, c.message_end_time, c.uncompressed_size)
        for o, c in by_offset.items()
        if o not in heads
    ]
    for offset, start, end, uncompressed in spans:
        counts = check.counts.get(offset, {})
        n = sum(counts.values())
        for cid, k in counts.items():
            indexed[cid] = indexed.get(cid, 0) + k
        has_index = bool(counts)
        if not has_index and uncompressed > 0:
            every_chunk_indexed = False
        if start <= end and (n > 0 or (not has_index and uncompressed > 0)):
            if not has_index and start == end == 0:
                # 0..0 without message indexes: how writers mark a chunk without messages
                # (schema and channel records only), or one of messages at t = 0 only
                zero_chunk = True
                continue
            starts.append(start)
            ends.append(end)
    if spans and every_chunk_indexed and not bare_messages:
        if {c: k for c, k in indexed.items() if k} != {c: k for c, k in stated.items() if k}:
            problems.append(
                f"its statistics count {statistics.message_count:,} messages, its message "
                f"indexes {sum(indexed.values()):,}"
            )
    else:
        under = any(stated.get(cid, 0) < k for cid, k in indexed.items())
        if under:
            problems.append(
                f"its statistics count {statistics.message_count:,} messages, fewer than its "
                f"message indexes list ({sum(indexed.values()):,})"
            )
        elif statistics.message_count == 0 and not every_chunk_indexed:
            check.unsure = True
    if (starts or zero_chunk) and statistics.message_count > 0:
        first, last = (min(starts), max(ends)) if starts else (0, 0)
        if statistics.message_start_time not in (first, *([0] if zero_chunk else [])):
            problems.append(
                "its statistics say the messages start at "
                f"{iso_utc(statistics.message_start_time)}, its chunks at {iso_utc(first)}"
            )
        if statistics.message_end_time != last:
            problems.append(
                f"its statistics say the messages end at {iso_utc(statistics.message_end_time)}, "
                f"its chunks at {iso_utc(last)}"
            )


def refused(index: Any, limits: ReadLimits) -> str | None:
    """Why the chunk a (checked) chunk index describes will not be read, from the index
    alone: an unknown compression, or more than the chunk cap; None when it may be read."""
    from aion_cli.formats import limits as caps

    if index.compression not in ("", "zstd", "lz4"):
        return str(caps.UnknownCompressionError(f"unknown compression {index.compression[:40]!r}"))
    size = index.uncompressed_size if index.compression else index.compressed_size
    if size > limits.max_chunk_bytes:
        return str(caps.chunk_over_limit(size, limits.max_chunk_bytes))
    return None


def chunks_overlap(indexes: list[Any]) -> bool:
    """Whether chunk indexes sorted by start time overlap in time (then the reader merges
    their messages instead of reading chunk after chunk)."""
    end = -1
    for index in indexes:
        if index.message_start_time < end:
            return True
        end = max(end, index.message_end_time)
    return False
