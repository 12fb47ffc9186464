"""``aion compact``: a query-only copy of a map, for the robot that only asks it questions.

A map carries two kinds of temporal accumulators: what its forecasts read (rates, profiles,
day-ahead scores, the pending day, the FreMEn components chosen when it was written) and the
per-entry Fourier sums Σ n·e^{iωt} over every candidate period and value bin, which only
*learning* needs: continuing the map with more logs (``aion build --map``) and merging it
(``aion merge``) add to them, and a new day's FreMEn components are chosen from them. They
are most of a map's bytes (31 periods × 9 value bins of complex128 per entry: 4.5 KB of the
5.8 KB of an entry with two weeks of history).

A query-only map is the same map file without those members (:data:`LEFT_OUT`), marked in its
manifest (``query_only``: the full map it was made from, by name, size and sha256, and the
members left out). Queries read a map without them anyway (``mapquery.load_map(...,
forecast_only=True)``: ``predict``, ``plan``, ``export``, ``report``, the Python API), so every
answer is the same, to the bit; a query-only map refuses to be continued or merged with a clear
error naming the full map. Maps that cannot answer without their sums are refused: part maps
(``aion build --part``: their days are held unscored for a merge), maps written before the
FreMEn components were stored, and maps whose stored components are stale (their seal does
not hold: ``aion_cli.derived_seal``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aion_cli.errors import InputError, MapFileError

#: the members a query-only map leaves out: the per-entry Fourier sums (their names as
#: ``engine.temporal.accumulator_files`` writes them)
LEFT_OUT = ("temporal_cnt_fourier", "temporal_obs_fourier")
#: the manifest field that marks a query-only map
FIELD = "query_only"


@dataclass
class CompactReport:
    """What ``aion compact`` did; ``to_dict`` is its ``--format json``."""

    source: Path
    output: Path
    source_bytes: int = 0
    map_bytes: int = 0
    entries: int = 0
    #: the latest graph's places that hold no entry (predict lists them, family "none")
    places_without_data: int = 0
    left_out: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def __repr__(self) -> str:
        """What the compaction did in one line, in the ``<aion.… >`` form of the other API
        objects: the map written, from which map, the bytes before and after, the entries."""
        from aion_cli.number_text import counted

        return (
            f"<aion.CompactReport {self.output} from {self.source}: {self.source_bytes:,} -> "
            f"{self.map_bytes:,} bytes; {self.entries:,} "
            f"entr{'y' if self.entries == 1 else 'ies'}; "
            f"{counted(len(self.notes), 'note')}>"
        )

    @property
    def ratio(self) -> float | None:
        """How many times smaller the copy is than the map it was made from (None: no copy
        written); the JSON's ``ratio``."""
        return self.source_bytes / self.map_bytes if self.map_bytes else None

    def to_dict(self) -> dict[str, Any]:
        ratio = self.ratio
        return {
            "map": str(self.output),
            "source": str(self.source),
            "source_bytes": self.source_bytes,
            "map_bytes": self.map_bytes,
            "ratio": ratio,
            "entries": self.entries,
            "places_without_data": self.places_without_data,
            "bytes_per_entry": self.map_bytes / self.entries if self.entries else None,
            "left_out": self.left_out,
            "notes": self.notes,
        }


def query_only_of(manifest: dict[str, Any]) -> dict[str, Any] | None:
    """The ``query_only`` record of a map's manifest (None: a full map);
    :class:`~aion_cli.errors.MapCorruptError` when the field is there but not a record (the
    check ``Manifest.from_dict`` makes, so ``aion info`` and the loaders agree)."""
    from aion_cli.manifest import parse_query_only

    return parse_query_only(manifest.get(FIELD))


def made_from(record: dict[str, Any]) -> str | None:
    """The file name of the full map a query-only map was made from (None: not recorded)."""
    source = record.get("from")
    name = source.get("name") if isinstance(source, dict) else None
    return name if isinstance(name, str) else None


def query_only_text(record: dict[str, Any]) -> str:
    """What a query-only map is, as ``aion info`` and ``aion report`` say it."""
    return (
        f"made from {made_from(record) or '?'} by aion compact: answers queries, cannot be "
        "continued or merged"
    )


def refuse_learning(path: Path, record: dict[str, Any] | None, what: str) -> None:
    """:class:`MapFileError` when the map at ``path`` is query-only (``record``, its
    :func:`query_only_of`): it cannot be ``what`` (continued, merged), its Fourier sums were
    left out."""
    if record is None:
        return
    name = made_from(record)
    raise MapFileError(
        f"{path} is a query-only map (made by aion compact): it answers queries, but cannot "
        f"be {what} (its Fourier sums were left out)",
        hint=f"use the full map it was made from{f' ({name})' if name else ''}",
    )


def compact_map(source: Path, output: Path) -> CompactReport:
    """Write the query-only copy of the map ``source`` to ``output`` (see the module
    docstring); ``output`` must be a new file or an aion map other than ``source`` (replaced
    atomically)."""
    from aion_cli.derived_seal import stale_because
    from aion_cli.engine.temporal import components
    from aion_cli.formats.mapfile import RESERVED_KEYS, check_map_output, open_map, write_map
    from aion_cli.mapquery import check_map_input, entry_counts
    from aion_cli.provenance import provenance

    check_map_input(source)
    if output.exists() and os.path.samefile(output, source):
        raise InputError(
            f"the output {output} is the map being compacted",
            hint="write the query-only map to a new file",
        )
    check_map_output(output)  # before a large map is read and hashed
    # said as build and merge say it: an existing map at -o is replaced
    notes = [f"{output.name} existed and is replaced"] if output.exists() else []
    with open_map(source, in_place=True) as members:
        manifest = members.manifest
        state = manifest.get("state")
        if query_only_of(manifest) is not None:
            raise InputError(f"{source} is a query-only map already", hint="nothing to do")
        if isinstance(state, dict) and state.get("deferred") is not None:
            raise InputError(
                f"{source} is a part map (aion build --part): its days are held for a merge, "
                "and a query-only map could not score them",
                hint="merge the part maps with aion merge, then compact the merged map",
            )
        names = list(members)
        if components.PREFIX + "total_index" not in names:
            raise InputError(
                f"{source} stores no FreMEn components (written by an older aion): its "
                "forecasts need the Fourier sums",
                hint="keep the full map, or rebuild it with this version of aion",
            )
        if (why := stale_because(manifest)) is not None:  # the copy could not recompute them
            raise InputError(
                f"{source}'s stored forecasts (forecast_*, provisional_*) are not its own "
                f"({why}): its queries compute them again from its Fourier sums, which a "
                "query-only map leaves out",
                hint="rebuild the map with aion build (its queries answer meanwhile)",
            )
        left_out = [n for n in names if n in LEFT_OUT]
        arrays = {n: members[n] for n in names if n not in LEFT_OUT}
        record = {"from": provenance(source), "left_out": left_out}
        fields = {k: v for k, v in manifest.items() if k not in RESERVED_KEYS}
        write_map(output, arrays, fields | {FIELD: record})
    entries, without = entry_counts(output)
    return CompactReport(
        source, output, source.stat().st_size, output.stat().st_size, entries, without,
        left_out, notes,
    )
