"""The pose-orientation rule's state at the start of each shard of a parallel build, found
before the shards run.

A build sets aside the pose yaws of a detection topic while its orientations have never varied
(a tracker that leaves every orientation at identity says nothing about headings), judged
message by message from the topic's first message on
(:meth:`aion_cli.detection_feed.DetectionFeeder.judge_orientations`). A shard built from
scratch cannot know whether the messages before it varied, so it judges its first messages
alone: a first message with one person in it (or people facing alike) loses its yaws there,
where one pass keeps them, and the fold had to learn the whole shard again in sequence.
Real trackers publish such messages all the time: on the Lincoln corridor two of three shards
fell back.

So the parent reads the first messages of the stream (at most :data:`SCAN_MESSAGES`, in log
order, with the build's own adapters and rule) and notes by when each topic's orientations
had varied. Every shard that starts after that is started with the topic marked as varied
(``ShardTask.yaw_seen``). The fold checks the assumption against the state the shards before
it really left (:func:`aion_cli.detection_feed.yaw_rule_blocker`): where it was wrong (the
build's time rules drop the message that varied, say), that shard is learnt in sequence, so
the map is the one pass's either way; the scan only decides how often that happens.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from aion_cli.build_options import BuildOptions
    from aion_cli.formats.logs import LogSet
    from aion_cli.topics import TopicPlan

SCAN_MESSAGES = 5_000
"""Detection messages read from the start of the stream at most (decoding them takes
milliseconds; a topic whose orientations have not varied by then keeps the fold's check)."""
_BATCH = 256


def varied_by(logset: LogSet, plan: TopicPlan, opts: BuildOptions) -> dict[str, int]:
    """Per detection topic of ``plan`` (the build's topics of the open ``logset``), the log
    time of the message at which its orientations first varied in one pass; a topic not
    seen to vary in the first :data:`SCAN_MESSAGES` messages is left out."""
    from itertools import islice

    from aion_cli.detection_adapters import log_adapters
    from aion_cli.detection_feed import DetectionCounts, DetectionFeeder, chunks

    out: dict[str, int] = {}
    topics = plan.names("detections")
    if not topics or SCAN_MESSAGES <= 0:
        return out
    adapters, factory, _ = log_adapters(logset, plan.detections, plan.mappings)
    feeder = DetectionFeeder(
        None, opts.map_frame, DetectionCounts(), adapters, factory, linker=None
    )
    first = islice(logset.messages(topics), SCAN_MESSAGES)
    for batch, _ in chunks(first, set(), _BATCH):
        out.update(feeder.judge_orientations(batch))
        if out.keys() >= topics:
            break
    return out


def shard_seeds(varied: dict[str, int], starts: list[int | None]) -> list[dict[str, float]]:
    """Per shard (``starts``: its first log time, None where unknown), the topics marked as
    varied at its start (NaN, the rule's state once orientations varied): those that varied
    before it. The first shard starts as one pass does, from scratch."""
    seeds: list[dict[str, float]] = []
    for k, start in enumerate(starts):
        if k == 0 or start is None:
            seeds.append({})
        else:
            seeds.append({t: float("nan") for t, at in sorted(varied.items()) if at < start})
    return seeds
