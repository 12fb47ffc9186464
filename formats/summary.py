"""What ``aion info`` reports about a set of logs: files, time range and every topic's role.

A topic's role says what ``aion build`` does with it: ``scene_graph`` (Hydra ``DsgUpdate``),
``detections`` (a type with a detection adapter), ``tf`` / ``tf_static`` (transforms) or
``unsupported``. Everything comes from the logs' indexes, no message is read; the spark_dsg payload
versions seen on scene-graph topics need the DSG decoder, so the CLI fills
:attr:`LogSummary.dsg_versions` itself.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

from aion_cli.engine.time_text import iso_utc
from aion_cli.formats.raw import normalize_msgtype

if TYPE_CHECKING:
    from aion_cli.formats.logs import LogSet

Role = Literal["scene_graph", "detections", "tf", "tf_static", "unsupported"]
ROLES: tuple[Role, ...] = ("scene_graph", "detections", "tf", "tf_static", "unsupported")

TF_TYPES = frozenset({"tf2_msgs/msg/TFMessage", "tf/msg/tfMessage"})


def detection_types() -> frozenset[str]:
    """Message types with a detection adapter: ``formats.detections.SUPPORTED_TYPES``."""
    from aion_cli.formats.detections import SUPPORTED_TYPES

    return frozenset(normalize_msgtype(t) for t in SUPPORTED_TYPES)


def role_of(topic: str, msgtype: str, detections: Iterable[str] | None = None) -> Role:
    """The role of ``topic`` carrying ``msgtype``. ``detections``: the types counted as
    detections (default :func:`detection_types`; add types a TOML mapping covers)."""
    msgtype = normalize_msgtype(msgtype)
    if msgtype.endswith("/DsgUpdate"):
        return "scene_graph"
    if msgtype in TF_TYPES:
        return "tf_static" if topic.rstrip("/").endswith("tf_static") else "tf"
    known = detection_types() if detections is None else frozenset(detections)
    if msgtype in known:
        return "detections"
    return "unsupported"


@dataclass(frozen=True)
class TopicSummary:
    """One topic: type, message count, mean rate over the time the files holding it
    recorded (:meth:`formats.logs.LogSet.recorded_ns`: one log's span; the time between
    logs of other days left out), role, wire encoding."""

    topic: str
    msgtype: str
    count: int
    role: Role
    encoding: str
    rate_hz: float | None
    readable: bool = True
    """False for a channel in an encoding no ROS reader decodes (JSON, protobuf, ...)."""

    def to_dict(self) -> dict[str, Any]:
        return {
            "topic": self.topic,
            "type": self.msgtype,
            "count": self.count,
            "role": self.role,
            "encoding": self.encoding,
            "rate_hz": None if self.rate_hz is None else _rate(self.rate_hz),
            "readable": self.readable,
        }


@dataclass(frozen=True)
class FileSummary:
    """One opened file or rosbag2 folder."""

    path: str
    format: str
    size_bytes: int
    message_count: int
    start_ns: int
    end_ns: int
    compression: tuple[str, ...] = ()
    """:attr:`formats.log_source.LogFile.compression` (empty: unknown)."""

    def to_dict(self) -> dict[str, Any]:
        """Its times are None without messages (the readers' 0 is no time: 1970-01-01)."""
        held = self.message_count > 0
        return {
            "path": self.path,
            "format": self.format,
            "size_bytes": self.size_bytes,
            "messages": self.message_count,
            "start_ns": self.start_ns if held else None,
            "end_ns": self.end_ns if held else None,
            "compression": list(self.compression),
        }


@dataclass
class LogSummary:
    """Everything ``aion info`` prints; :meth:`to_dict` is the ``--json`` form."""

    files: list[FileSummary]
    topics: list[TopicSummary]
    start_ns: int
    end_ns: int
    recorded_ns: int = 0
    """How long the logs recorded (:meth:`formats.logs.LogSet.recorded_total_ns`): the days
    between two logs left out, unlike :attr:`span_s`."""
    recordings: int = 0
    """How many recordings hold messages (a path given; one rosbag2 bag's files are one)."""
    warnings: list[str] = field(default_factory=list)
    dsg_versions: dict[str, list[str]] = field(default_factory=dict)
    """Scene-graph topic -> spark_dsg payload versions seen (filled by the CLI)."""

    @property
    def formats(self) -> list[str]:
        """Container formats of the files, each once, in file order."""
        return list(dict.fromkeys(f.format for f in self.files))

    @property
    def compression(self) -> list[str]:
        """The files' compressions, each once, in file order."""
        return list(dict.fromkeys(c for f in self.files for c in f.compression))

    @property
    def span_s(self) -> float:
        """From the first message to the last, the time between logs included."""
        return max(self.end_ns - self.start_ns, 0) / 1e9

    @property
    def duration_s(self) -> float:
        """:attr:`span_s` (the JSON's ``duration_s``, kept for scripts that read it)."""
        return self.span_s

    @property
    def recorded_s(self) -> float:
        """How long the logs recorded (:attr:`recorded_ns`), in seconds."""
        return self.recorded_ns / 1e9

    @property
    def message_count(self) -> int:
        """Messages on topics a ROS reader decodes (the others' are in the files' counts)."""
        return sum(t.count for t in self.topics if t.readable)

    @property
    def size_bytes(self) -> int:
        return sum(f.size_bytes for f in self.files)

    def by_role(self, role: Role) -> list[TopicSummary]:
        """Topics with ``role``, in topic order."""
        return [t for t in self.topics if t.role == role]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: plain str/int/float/list/dict values only; the times are None
        when no file holds a message (the table's "duration: none"), not 1970-01-01."""
        held = any(f.message_count > 0 for f in self.files)
        return {
            "formats": self.formats,
            "files": [f.to_dict() for f in self.files],
            "size_bytes": self.size_bytes,
            "compression": self.compression,
            "start_ns": self.start_ns if held else None,
            "end_ns": self.end_ns if held else None,
            "start": iso_utc(self.start_ns) if held else None,
            "end": iso_utc(self.end_ns) if held else None,
            "duration_s": round(self.duration_s, 6),
            "span_s": round(self.span_s, 6),
            "recorded_s": round(self.recorded_s, 6),
            "recordings": self.recordings,
            "messages": self.message_count,
            "topics": [t.to_dict() for t in self.topics],
            "roles": {role: [t.topic for t in self.by_role(role)] for role in ROLES},
            "dsg_versions": {k: list(v) for k, v in self.dsg_versions.items()},
            "warnings": list(self.warnings),
        }


def summarize(logset: LogSet, detections: Iterable[str] | None = None) -> LogSummary:
    """Summary of ``logset`` from its indexes (reads no message). ``detections``: extra
    message types to count as detections (e.g. those a TOML mapping covers)."""
    known = detection_types() | frozenset(normalize_msgtype(t) for t in detections or ())
    others = logset.other_channels
    names = {t.topic for t in logset.topics} | {c.topic for c in others}
    spans_s = {topic: logset.recorded_ns(topic) / 1e9 for topic in names}

    def rate(topic: str, count: int) -> float | None:  # one message: no rate
        return count / spans_s[topic] if spans_s[topic] > 0 and count > 1 else None

    topics = [
        TopicSummary(
            topic=t.topic,
            msgtype=t.msgtype,
            count=t.count,
            role=role_of(t.topic, t.msgtype, known),
            encoding=t.encoding,
            rate_hz=rate(t.topic, t.count),
        )
        for t in logset.topics
    ]
    topics += [  # channels in other encodings: there, counted, never read
        TopicSummary(c.topic, c.schema, c.count, "unsupported", c.encoding,
                     rate(c.topic, c.count), readable=False)
        for c in others
    ]  # fmt: skip
    topics.sort(key=lambda t: t.topic)
    files = [
        FileSummary(
            str(f.path), f.format, f.size_bytes, f.message_count, f.start_ns, f.end_ns,
            f.compression,
        )
        for f in logset.files
    ]
    return LogSummary(
        files=files,
        topics=topics,
        start_ns=logset.start_ns,
        end_ns=logset.end_ns,
        recorded_ns=logset.recorded_total_ns(),
        recordings=len(logset.recording_times()),
        warnings=list(logset.warnings),
    )


def _rate(hz: float) -> float:
    """A rate for JSON: three decimals, or three significant digits below 1 Hz, so a topic of
    one message an hour is 0.000278 Hz, not 0.0, and a 1071.245 Hz one not 1070.0."""
    return round(hz, 3) if hz >= 1 else float(f"{hz:.3g}")
