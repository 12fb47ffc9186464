"""The map file's manifest as a typed record: what a map holds beside its arrays.

``formats.mapfile`` stores a manifest as JSON and adds the container's own keys (``format``,
``version``, ``creator``, ``created``, ``members``); this module gives the fields aion writes a
type, one reader and one writer, so that the build, the query commands, ``aion info`` and the
Python API never read it by string keys. A manifest from a file is validated here: a field of
the wrong type is :class:`~aion_cli.errors.MapCorruptError` (exit 2), never a
``KeyError`` later.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from aion_cli.errors import MapCorruptError


@dataclass(frozen=True)
class InputLog:
    """One log a map was built from: its path when it was read, file name, size, sha256."""

    path: str
    name: str
    size: int
    sha256: str

    @classmethod
    def from_dict(cls, d: Any) -> InputLog:
        if not isinstance(d, dict):
            raise _bad("inputs", "an input is not an object")
        try:
            return cls(str(d["path"]), str(d["name"]), int(d["size"]), str(d["sha256"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise _bad("inputs", f"an input lacks {exc}") from exc

    def to_dict(self) -> dict[str, Any]:
        return {"path": self.path, "name": self.name, "size": self.size, "sha256": self.sha256}


@dataclass(frozen=True)
class Manifest:
    """The fields aion writes into a map's manifest (see formats/MAPFILE.md).

    ``state`` is the model state's own metadata (``MapState.to_arrays``), ``config`` the model
    parameters (``ModelConfig.to_dict``), ``counts`` the detections read / used / dropped over
    every build plus the state's sizes, ``last_build`` the detections of the latest build,
    ``families`` the model families in use; ``container`` holds the keys the map file itself
    adds (format, version, creator, created), empty before the map is written."""

    state: dict[str, Any]
    config: dict[str, Any]
    inputs: tuple[InputLog, ...] = ()
    start_ns: int | None = None
    end_ns: int | None = None
    counts: dict[str, Any] = field(default_factory=dict)
    last_build: dict[str, Any] = field(default_factory=dict)
    graph_source: str = "none"
    observation: str = "fixed"
    timezone: str | None = None
    families: dict[str, Any] = field(default_factory=dict)
    #: a merged map's input map files (name, path, size, sha256) and the lineage used
    #: (``aion merge``); kept when the map is continued with ``aion build --map``
    merged_from: tuple[dict[str, Any], ...] = ()
    lineage: str | None = None
    #: a query-only map's record (``aion compact``): the full map it was made from (name,
    #: path, size, sha256) and the members left out; None for a full map
    query_only: dict[str, Any] | None = None
    #: the fixed frame the map's positions are in (``aion build --map-frame``); None for maps
    #: written before it was recorded, and for a merge of maps in different frames
    map_frame: str | None = None
    #: a part map's ``--observed`` spans ``[lo, hi)`` of log time (every build of it): a
    #: merge fills the declared windows between the part's logs and those before it with
    #: them, as one build of all the logs does; empty for other maps
    observed_spans: tuple[tuple[int, int], ...] = ()
    #: per build of the map's logs (every build of every map merged into it): the logs'
    #: names and sha256s and a sample of their detections (``recording_twins``: one
    #: recording in two log files is refused when merged or continued); none in older maps
    recordings: tuple[dict[str, Any], ...] = ()
    #: the seal of the map's derived members as read (``aion_cli.derived_seal``; not shown,
    #: and written afresh by every write: ``write_map(..., seal=...)`` replaces it); None in
    #: maps written before it
    derived: dict[str, Any] | None = None
    container: dict[str, Any] = field(default_factory=dict)

    def __repr__(self) -> str:
        """What the map file says of itself in one line (not its model parameters, every
        input's checksum and every place's label, which a notebook would print whole for
        ``m.manifest``): its time span, detections used, logs, nodes and cells, zone."""
        from aion_cli.number_text import counted

        span = "no time span"
        if self.start_ns is not None and self.end_ns is not None:
            from aion_cli.engine.time_text import format_ns
            from aion_cli.timeparse import resolve_zone

            zone = resolve_zone(self.timezone or "UTC")
            span = f"{format_ns(self.start_ns, zone)} .. {format_ns(self.end_ns, zone)}"
        used, nodes, cells = (
            int(v) if isinstance(v := self.counts.get(k), int | float) else 0
            for k in ("used", "nodes", "cells")
        )
        return (
            f"<aion.Manifest: {span}; {counted(used, 'detection')} used from "
            f"{counted(len(self.inputs), 'log')}; {counted(nodes, 'node')}, "
            f"{counted(cells, 'cell')}>"
        )

    @property
    def recording_reach(self) -> int | None:
        """The last window a fixed sensor's logs reached over every build (``counts``), None
        where unknown (no fixed sensor, older maps, a damaged value): where a continued
        build's logs and its ``--observed`` spans take over."""
        reach = self.counts.get("recording_reach")
        return reach if type(reach) is int else None

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Manifest:
        """A manifest read from a map file (container keys kept in ``container``)."""
        state = d.get("state")
        if not isinstance(state, dict):
            raise MapCorruptError("the map has no model state", hint="rebuild it with aion build")
        span = _dict(d, "time_span")
        inputs = d.get("inputs", [])
        if not isinstance(inputs, list):
            raise _bad("inputs", "not a list")
        zone = d.get("timezone")
        return cls(
            state=state,
            config=_stored_config(_dict(d, "config")),
            inputs=tuple(InputLog.from_dict(i) for i in inputs),
            start_ns=_optional_int(span.get("start_ns"), "time_span"),
            end_ns=_optional_int(span.get("end_ns"), "time_span"),
            counts=_dict(d, "counts"),
            last_build=_dict(d, "last_build"),
            graph_source=str(d.get("graph_source", "none")),
            observation=str(d.get("observation", "fixed")),
            timezone=zone if isinstance(zone, str) else None,
            families=_dict(d, "families"),
            merged_from=_merged_from(d.get("merged_from")),
            lineage=str(d["lineage"]) if isinstance(d.get("lineage"), str) else None,
            query_only=parse_query_only(d.get("query_only")),
            map_frame=str(d["map_frame"]) if isinstance(d.get("map_frame"), str) else None,
            observed_spans=_spans(d.get("observed_spans")),
            recordings=_objects(d.get("recordings"), "recordings"),
            derived=d["derived"] if isinstance(d.get("derived"), dict) else None,
            container={k: d[k] for k in ("format", "version", "creator", "created") if k in d},
        )

    def to_dict(self) -> dict[str, Any]:
        """The fields to store (``formats.mapfile.write_map`` adds the container's keys)."""
        return {
            "state": self.state,
            "config": self.config,
            "inputs": [i.to_dict() for i in self.inputs],
            "time_span": {"start_ns": self.start_ns, "end_ns": self.end_ns},
            "counts": self.counts,
            "last_build": self.last_build,
            "graph_source": self.graph_source,
            "observation": self.observation,
            "timezone": self.timezone,
            "families": self.families,
        } | (
            {"merged_from": list(self.merged_from), "lineage": self.lineage}
            if self.merged_from
            else {}
        ) | ({"query_only": self.query_only} if self.query_only is not None else {}) | (
            {"map_frame": self.map_frame} if self.map_frame is not None else {}
        ) | (
            {"observed_spans": [list(span) for span in self.observed_spans]}
            if self.observed_spans
            else {}
        ) | ({"recordings": list(self.recordings)} if self.recordings else {}) | (
            {"derived": self.derived} if self.derived is not None else {}
        )

    def shown(self) -> dict[str, Any]:
        """What ``aion info MAP`` shows: the stored fields and the container's, without the
        internal state table nor the samples of the logs' detections (``recordings``) nor
        the seal of its derived members (``derived``; a part map's ``part``: how many days it
        holds unscored)."""
        hidden = ("state", "recordings", "derived")
        out = {k: v for k, v in self.to_dict().items() if k not in hidden}
        deferred = self.state.get("deferred")
        if isinstance(deferred, dict):  # a part map (aion build --part): its days held
            days = deferred.get("days")
            out["part"] = {"held_days": len(days) if isinstance(days, list) else 0}
        return self.container | out

    def joined_span(self, start: int | None, end: int | None) -> tuple[int | None, int | None]:
        """``start``..``end`` widened to this map's time span (a continued build's)."""
        if self.start_ns is not None:
            start = self.start_ns if start is None else min(start, self.start_ns)
        if self.end_ns is not None:
            end = self.end_ns if end is None else max(end, self.end_ns)
        return start, end

    @property
    def input_hashes(self) -> set[str]:
        """The sha256 of every log already in the map (a log is added at most once)."""
        return {i.sha256 for i in self.inputs}


def days_scored_text(shown: dict[str, Any]) -> str | None:
    """The days the map's day-ahead scoring judged (an entry leaves ``static`` only on its
    scores), as ``aion info MAP`` and ``aion report`` show them, from :meth:`Manifest.shown`:
    ``"3 (the last, still open to more logs, provisionally)"``; None for a map that does not
    say (families not counted)."""
    families = shown.get("families") or {}
    if "scored_days" not in families:
        return None
    days = int(families["scored_days"])
    last = ""
    if families.get("last_day_provisional"):  # a query-only map is continued no more
        last = (" (the last provisionally, as it stood when compacted)"
                if isinstance(shown.get("query_only"), dict)
                else " (the last, still open to more logs, provisionally)")
    return f"{days:,}{last}"


def parse_query_only(value: Any) -> dict[str, Any] | None:
    """The ``query_only`` field (``aion compact``) checked: None, or an object whose
    ``left_out`` is a list; :class:`MapCorruptError` otherwise."""
    if value is None:
        return None
    if not isinstance(value, dict) or not isinstance(value.get("left_out", []), list):
        raise _bad("query_only", "expected an object with a list of members left out")
    return value


def _merged_from(value: Any) -> tuple[dict[str, Any], ...]:
    return _objects(value, "merged_from")


def _objects(value: Any, key: str) -> tuple[dict[str, Any], ...]:
    """A list of objects (``merged_from``, ``recordings``); none when absent."""
    if value is None:
        return ()
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise _bad(key, "expected a list of objects")
    return tuple(value)


def _spans(value: Any) -> tuple[tuple[int, int], ...]:
    if value is None:
        return ()
    if not isinstance(value, list) or not all(
        isinstance(v, list) and len(v) == 2 and all(type(x) is int for x in v) for v in value
    ):
        raise _bad("observed_spans", "expected a list of [start_ns, end_ns] pairs")
    return tuple((int(a), int(b)) for a, b in value)


def part_spans(
    previous: Manifest | None, declared: tuple[tuple[int, int], ...]
) -> tuple[tuple[int, int], ...]:
    """A part map's ``observed_spans``: its earlier builds' and this one's, sorted, once each."""
    before = previous.observed_spans if previous is not None else ()
    return tuple(sorted(set(before) | {(int(a), int(b)) for a, b in declared}))


def _stored_config(config: dict[str, Any]) -> dict[str, Any]:
    """The manifest's model configuration as the map reads it (keys an older version did not
    write filled in as it built: :func:`~aion_cli.engine.config.stored_config`); none stays
    none."""
    from aion_cli.engine.config import stored_config

    return stored_config(config) if config else config


def _bad(key: str, why: str) -> MapCorruptError:
    return MapCorruptError(
        f"the map's manifest is invalid: {key}: {why}", hint="rebuild the map with aion build"
    )


def _dict(d: dict[str, Any], key: str) -> dict[str, Any]:
    value = d.get(key, {})
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _bad(key, f"expected an object, got {type(value).__name__}")
    return value


def _optional_int(value: Any, key: str) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise _bad(key, f"expected an integer time, got {value!r}")
    return value


def add_counts(old: dict[str, Any], new: dict[str, Any], *, meet: bool = False) -> dict[str, Any]:
    """The detections read / used / dropped (by reason) of a map's earlier builds (``old``,
    its manifest's ``counts``) plus those of a new build (``new``): the ``counts`` a continued
    map stores. ``recording_windows`` (a fixed sensor's logs' own time, in windows) adds up
    while every part has it (``old`` empty: the first part), and is left out otherwise;
    ``empty_messages`` (detection messages that held no detection) adds up while every part
    counted them, and is kept once one part saw some; ``recording_reach`` and
    ``recording_first``, the last and the first of those windows, are
    the latest and the earliest of the parts' while every part has them. ``meet`` (maps built
    apart, merged): the window in which one part's logs end and the other's begin is counted
    once (a continued build counts only the windows after the map's reach to begin with)."""
    dropped = dict(old.get("dropped", {}))
    for reason, n in new["dropped"].items():
        dropped[reason] = int(dropped.get(reason, 0)) + int(n)
    out = {
        "read": int(old.get("read", 0)) + new["read"],
        "used": int(old.get("used", 0)) + new["used"],
        "dropped": dict(sorted(dropped.items())),
    }
    # detection messages that held no detection: kept while every part counted them (older
    # maps did not: unknown), or as soon as one part saw some (its tracker publishes them)
    empty = (old.get("empty_messages", 0 if not old else None), new.get("empty_messages"))
    known = [v for v in empty if type(v) is int]
    if len(known) == 2 or sum(known) > 0:
        out["empty_messages"] = sum(known)
    before, added = old.get("recording_windows", 0 if not old else None), new.get(
        "recording_windows"
    )
    if type(before) is int and type(added) is int:  # a damaged manifest's value is left out
        out["recording_windows"] = before + added
        parts = [c for c in (old, new) if c]
        for key, pick in (("recording_reach", max), ("recording_first", min)):
            values = [c.get(key) for c in parts]
            if all(type(v) is int for v in values):  # older maps have none
                out[key] = pick(int(v) for v in values if v is not None)
        if meet and old and _meeting(old, new):
            out["recording_windows"] -= 1
    return out


def _meeting(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether the logs of counts ``a`` and ``b`` both recorded in one window: one's last
    (``recording_reach``) is the other's first (``recording_first``); unknown for older maps."""
    ends = [c.get(k) for c in (a, b) for k in ("recording_first", "recording_reach")]
    if not all(type(v) is int for v in ends):
        return False
    a_first, a_reach, b_first, b_reach = ends
    return bool(a_reach == b_first or b_reach == a_first)
