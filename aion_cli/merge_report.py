"""What ``aion merge`` did (:class:`MergeReport`; its ``to_dict`` is ``aion merge --format
json``) and each input map's part in it (:class:`MergedInput`). Beside
:mod:`aion_cli.merging`, which fills them in, as :mod:`aion_cli.build_report` is beside the
build."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aion_cli.manifest import InputLog


@dataclass(frozen=True)
class MergedInput:
    """One input map: its file's provenance, time span, logs and detections."""

    file: InputLog
    start_ns: int | None
    end_ns: int | None
    logs: int
    detections: int

    def to_dict(self) -> dict[str, Any]:
        return self.file.to_dict() | {
            "start_ns": self.start_ns,
            "end_ns": self.end_ns,
            "logs": self.logs,
            "detections": self.detections,
        }


@dataclass
class MergeReport:
    """What a merge did; ``to_dict`` is ``aion merge --format json``."""

    output: Path
    inputs: list[MergedInput] = field(default_factory=list)
    lineage: str = "same"
    lineage_reason: str = ""
    graph_source: str = "none"
    released: int = 0
    rebound: int = 0
    parts: int = 0  # part maps (aion build --part) joined with their days scored at the merge
    detections: int = 0
    logs: int = 0
    cells: int = 0
    nodes: int = 0
    nodes_with_flow: int = 0
    bound_cells: int = 0
    windows: int = 0
    hours_observed: str | None = None  # per kind of day, as aion info MAP shows them
    timezone: str = "UTC"  # the merged map's zone, whose clock the CLI shows times on
    start_ns: int | None = None
    end_ns: int | None = None
    notes: list[str] = field(default_factory=list)
    #: what the map may hold wrongly, as aion build warns of it (nearly every detection away
    #: from the graph's places: another site's --graph, another frame)
    warnings: list[str] = field(default_factory=list)
    map_bytes: int = 0

    def __repr__(self) -> str:
        """What the merge did in one line (not each input's provenance): the map, the maps
        joined, the lineage, the detections and logs, and how many notes and warnings."""
        from aion_cli.number_text import counted

        return (
            f"<aion.MergeReport {self.output}: {counted(len(self.inputs), 'map')} merged, lineage "
            f"{self.lineage}; {counted(self.detections, 'detection')} from "
            f"{counted(self.logs, 'log')}; {counted(self.nodes, 'node')}, "
            f"{counted(self.cells, 'cell')}, {counted(self.windows, 'window')}; "
            f"{counted(len(self.notes), 'note')}, {counted(len(self.warnings), 'warning')}>"
        )

    def to_dict(self) -> dict[str, Any]:
        span = None
        if self.start_ns is not None and self.end_ns is not None:
            span = (self.end_ns - self.start_ns) / 1e9
        return {
            "map": str(self.output),
            "map_bytes": self.map_bytes,
            "inputs": [i.to_dict() for i in self.inputs],
            "lineage": self.lineage,
            "parts": self.parts,
            "lineage_reason": self.lineage_reason,
            "graph_source": self.graph_source,
            "released_nodes": self.released,
            "rebound_cells": self.rebound,
            "detections": self.detections,
            "logs": self.logs,
            "cells": self.cells,
            "nodes": self.nodes,
            "nodes_with_flow": self.nodes_with_flow,
            "bound_cells": self.bound_cells,
            "windows": self.windows,
            "hours_observed": self.hours_observed,
            "time_span": {"start_ns": self.start_ns, "end_ns": self.end_ns, "seconds": span},
            "notes": list(self.notes),
            "warnings": list(self.warnings),
        }
