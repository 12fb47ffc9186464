"""Which detection frames a log's TF cannot bring into the map frame, found before a build.

``aion info`` reads the first messages of every detection topic (their frames; of several
logs, each log's first messages too: one log's tracker may write in another frame) and the first
messages of every TF topic (the static transforms all come early; the dynamic ones name their
frames from the start), joins the frames the transforms connect, and names the detection
frames left apart from ``map``. A build would stop on them with "no TF to 'map'"; info says
so first, with the ``--map-frame`` that builds such a log. Reading a sample keeps info fast on
any log; a chain that only later TF messages complete is reported too (the note says what was
read).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import islice
from typing import TYPE_CHECKING, Any

from aion_cli.build_options import DEFAULT_MAP_FRAME, BuildOptions

if TYPE_CHECKING:
    from aion_cli.formats.tf import TfBuffer
    from aion_cli.formats.tf_norms import NormTally

#: detection messages per topic whose frames are read
DETECTION_SAMPLE = 20
#: TF messages per TF topic that are read
TF_SAMPLE = 500


@dataclass
class FrameReport:
    """What :func:`unconnected_frames` found: per detection topic, its frames the TF sample
    does not connect to ``map`` (``apart``); for each such frame that TF knows, the frame at
    the top of its tree (``roots``: what ``--map-frame`` would build in, when ``map -> odom``
    is missing); warnings on the TF sample (transforms a build ignores); and ``no_robot``,
    the warning a build gives when TF moves frames in ``map`` but not ``base_link``
    (:func:`aion_cli.tf_trajectory.wrong_base_warning`), for a log without scene-graph robot
    poses."""

    apart: dict[str, list[str]] = field(default_factory=dict)
    roots: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    no_robot: str | None = None
    read_as: dict[str, str] = field(default_factory=dict)
    """Per detection topic, how its reader takes it, where that needs saying (a Marker topic:
    :meth:`~aion_cli.formats.detections.markers.MarkerExtractor.describe`)."""
    empty_messages: int = 0
    """Messages of the detection samples that held no detection (``DetectionCounts.
    count_empty``): a tracker that publishes them is not silent when nobody is there."""


def unconnected_frames(logset: Any, plan: Any, mappings: list[Any]) -> FrameReport:
    """Per detection topic of ``plan``, the frames of its first messages that the log's TF
    (its first messages per TF topic) does not connect to ``map``; topics whose frames are
    all connected, or that cannot be decoded (the build reports those), are left out."""
    from aion_cli.formats.tf import normalize_frame
    from aion_cli.formats.tf_tree import root, unusable_text
    from aion_cli.tf_trajectory import wrong_base_warning

    out = FrameReport()
    frames = detection_frames(logset, plan, mappings, out)
    if not frames:
        return out
    tf, norms = _tf_sample(logset, plan)
    if norms.text():
        out.warnings.append(f"{norms.text()} (in the first {TF_SAMPLE} messages per TF topic)")
    if tf.unusable:
        out.warnings.append(
            f"TF transforms a build ignores: {unusable_text(tf.unusable)} (in the first "
            f"{TF_SAMPLE} messages per TF topic)"
        )
    out.no_robot = wrong_base_warning(tf, DEFAULT_MAP_FRAME, BuildOptions.base_frame)
    linked = tf.connected(DEFAULT_MAP_FRAME)
    known = set(tf.frames)
    for topic, names in frames.items():
        apart = sorted(
            f for f in {normalize_frame(n) for n in names} if f and f not in linked
        )
        if apart:
            out.apart[topic] = apart
        out.roots.update({f: root(tf.edges, f) for f in apart if f in known})
    return out


def detection_frames(
    logset: Any, plan: Any, mappings: list[Any], report: FrameReport | None = None
) -> dict[str, set[str]]:
    """The frames of each detection topic's first :data:`DETECTION_SAMPLE` messages, decoded
    as the build decodes them (with ``mappings``, the ``--detections-mapping`` topics); the
    messages among them that held no detection are counted into ``report``, and how a
    Marker topic is read (``report.read_as``)."""
    from aion_cli.detection_adapters import log_adapters
    from aion_cli.detection_counts import DetectionCounts
    from aion_cli.errors import AionError

    try:
        adapters, _factory, _notes = log_adapters(
            logset, plan.detections, {m.topic: m for m in mappings}
        )
    except AionError:
        return {}
    out: dict[str, set[str]] = {}
    topics = [info.topic for info in plan.detections]
    samples = first_of_each(logset, topics, DETECTION_SAMPLE)
    later = _other_logs_samples(logset, topics, samples)
    for info in plan.detections:
        sample = samples.get(info.topic, [])
        adapter = adapters.get((info.topic, info.msgtype, info.encoding))
        said = getattr(adapter.extract, "describe", None) if adapter is not None else None
        if report is not None and said is not None and said():
            report.read_as[info.topic] = said()
        if adapter is None or not sample:
            continue
        try:
            decoded = adapter.decode(sample)
        except AionError:
            continue
        out[info.topic] = set(decoded.frame_names()) | _frames(adapter, later.get(info.topic))
        if report is not None:
            counts = DetectionCounts()
            counts.count_empty(decoded)
            report.empty_messages += counts.empty_messages
            kept_none = _kept_none(info.topic, len(sample), decoded, counts)
            report.warnings += [kept_none] if kept_none is not None else []
    return out


def _other_logs_samples(
    logset: Any, topics: list[str], samples: dict[str, list[Any]]
) -> dict[str, list[Any]]:
    """Per topic of ``topics``, the first :data:`DETECTION_SAMPLE` messages of each log given
    (recording) that holds it but has none in ``samples`` (the set's first messages): a log
    whose tracker wrote in another frame (leg_tracker's 'rear_laser' beside 'right_laser')
    is named before the build meets it. Each log's topics are read together
    (:func:`first_of_each`: a few passes, not one per topic). Nothing for a set of one log."""
    from aion_cli.formats.raw import recordings_of

    holders = {t: set(logset.recording_times([t])) for t in topics}
    every = set().union(*holders.values())
    if len(every) < 2:
        return {}
    sampled = {t: set(recordings_of(samples.get(t, [])).tolist()) for t in topics}
    out: dict[str, list[Any]] = {}
    for recording in sorted(every):
        short = [t for t in topics if recording in holders[t] - sampled[t]]
        if short:
            got = first_of_each(_OneLog(logset, recording), short, DETECTION_SAMPLE)
            for topic, messages in got.items():
                out.setdefault(topic, []).extend(messages)
    return out


@dataclass
class _OneLog:
    """One recording of a log set, read as :func:`first_of_each` reads a set."""

    logset: Any
    recording: int

    def messages(self, topics: list[str], between: tuple[int, int] | None = None) -> Any:
        return self.logset.recording_messages(self.recording, topics, between)


def _frames(adapter: Any, messages: list[Any] | None) -> set[str]:
    """The frames of ``messages`` decoded by ``adapter`` (none when they cannot be: the build
    reports those)."""
    from aion_cli.errors import AionError

    if not messages:
        return set()
    try:
        return set(adapter.decode(messages).frame_names())
    except AionError:
        return set()


def _kept_none(topic: str, messages: int, decoded: Any, counts: Any) -> str | None:
    """The warning of a sample whose items a ``--detections-mapping`` dropped, every one, by
    its filter or its paths (short arrays), in the words of the hint ``aion build`` then
    fails with (:func:`aion_cli.build_hints.no_detection_hint`); None where the sample kept
    someone, or held nobody, or the class filter of a built-in type dropped its items (the
    first messages of a tracker may well be of other classes)."""
    from aion_cli.build_hints import no_detection_hint

    counts.add_decoded(counts.topic(topic), decoded.filtered)
    if len(decoded) or not (counts.dropped.get("filter") or counts.dropped.get("short_array")):
        return None
    hint = no_detection_hint([topic], counts.dropped, counts.filter_seen)
    return (
        f"{topic}: no item of its first {messages:,} message(s) is kept (aion build would "
        f"stop on it if none later is): {hint.removesuffix('; ')}"
    )


def _tf_sample(logset: Any, plan: Any) -> tuple[TfBuffer, NormTally]:
    """The first :data:`TF_SAMPLE` messages of each TF topic in a buffer (read as a build
    reads TF: :class:`aion_cli.tf_feed.TfReader`), and their rotations tf2 would refuse."""
    from aion_cli.formats.tf import TfBuffer
    from aion_cli.tf_feed import TfReader, TfStats

    reader = TfReader(logset, TfBuffer(), TfStats())
    for info in plan.tf:
        reader.add(_first(logset, info.topic, TF_SAMPLE))
    return reader.buffer, reader.stats.norms


def _first(logset: Any, topic: str, n: int) -> list[Any]:
    return list(islice(logset.messages([topic]), n))


def first_of_each(logset: Any, topics: list[str], n: int) -> dict[str, list[Any]]:
    """The first ``n`` messages of each of ``topics``: what :func:`_first` gives per topic,
    read in a few passes instead of one per topic (a log of 3,000 camera topics read its
    chunks 3,000 times). A pass reads the topics not yet full from where the last pass
    stopped; it stops once at most half of its topics are still short of ``n``, so a topic
    with few messages is finished by a pass of short topics only (chunks without them
    skipped by the index), as its own read did. A topic's messages come in the same order
    whichever topics are read with it; the messages already taken at the resumed log time
    are skipped by count."""
    out: dict[str, list[Any]] = {t: [] for t in dict.fromkeys(topics)}
    short = [t for t in out if n > 0]
    since = 0  # log time the pass resumes at
    while short:
        taken_at = {t: sum(1 for m in out[t] if m.log_time_ns == since) for t in short}
        stream = logset.messages(short, between=(since, 2**63 - 1))
        left = set(short)
        for msg in stream:
            topic = msg.topic
            if topic not in left or msg.log_time_ns < since:
                continue
            if msg.log_time_ns == since and taken_at[topic]:
                taken_at[topic] -= 1
                continue
            got = out[topic]
            got.append(msg)
            since = msg.log_time_ns
            if len(got) >= n:
                left.discard(topic)
                if 2 * len(left) <= len(short):
                    break
        else:
            break  # the log is read to its end: every topic has what it holds
        close = getattr(stream, "close", None)
        if close is not None:
            close()
        short = [t for t in short if t in left]
    return out


def tf_root(logset: Any) -> tuple[str | None, bool]:
    """The one frame at the top of the log's TF tree (its first :data:`TF_SAMPLE` messages per
    TF topic), as ``--suggest-mapping`` offers for ``frame_override``: turtlesim's ``world``;
    None without TF, or when its frames hang from more than one root. Beside it, whether the
    tree holds the frame ``map`` (a build's default ``--map-frame``, which TF must join to
    the detections' frame)."""
    from aion_cli.formats.tf_tree import root
    from aion_cli.topics import select_topics

    tf, _ = _tf_sample(logset, select_topics(logset.topics))
    tops = {root(tf.edges, f) for f in tf.frames}
    return (tops.pop() if len(tops) == 1 else None), "map" in tf.frames
