"""The batch path (issue 15): hundreds of messages decoded by one call of the numpy fast
decoder -- as a build's decode job does -- give exactly what rosbags gives decoding each
message on its own (``DetectionAdapter.decode_generic``, one message at a time), for the four
fast types in both encodings; the messages differ in size, so their payloads start at every
alignment of the joined buffer."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.formats.detections import FrameDetections, adapter_for
from aion_cli.formats.raw import RawMessage
from tests.formats.detection_strategies import (
    DET3D,
    PEOPLE,
    POSE_ARRAY,
    TRACKED,
    detections,
    headers,
    persons,
    poses,
    tracked,
)
from tests.formats.ros_messages import raw

SETTINGS = settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _specs(msgtype: str, ros: int) -> st.SearchStrategy[dict[str, Any]]:
    if msgtype == POSE_ARRAY:
        return st.builds(lambda h, p: {"header": h, "poses": p}, headers(),
                         st.lists(poses(), max_size=9))
    if msgtype == TRACKED:
        return st.builds(lambda h, t: {"header": h, "tracks": t}, headers(),
                         st.lists(tracked(), max_size=9))
    if msgtype == PEOPLE:
        return st.builds(lambda h, p: {"header": h, "people": p}, headers(),
                         st.lists(persons(), max_size=6))
    return st.builds(lambda h, d: {"header": h, "detections": d}, headers(),
                     st.lists(detections(ros), max_size=4))


def _one_by_one(msgtype: str, msgs: list[RawMessage]) -> FrameDetections:
    adapter = adapter_for(msgtype)
    assert adapter is not None
    parts = [adapter.decode_generic([m]) for m in msgs]
    return FrameDetections.concat(parts)


@pytest.mark.parametrize("ros", [1, 2])
@pytest.mark.parametrize("msgtype", [POSE_ARRAY, TRACKED, PEOPLE, DET3D])
@SETTINGS
@given(data=st.data())
def test_many_messages_at_once_equal_rosbags_one_by_one(
    msgtype: str, ros: int, data: st.DataObject
) -> None:
    specs = data.draw(st.lists(_specs(msgtype, ros), min_size=1, max_size=5))
    seed = data.draw(st.integers(0, 2**32 - 1))
    n = data.draw(st.integers(50, 400))
    pick = np.random.default_rng(seed).integers(0, len(specs), n).tolist()
    distinct = [raw(msgtype, s, ros) for s in specs]
    msgs = [
        RawMessage("/t", msgtype, 1000 + i, distinct[k].data, distinct[k].encoding)
        for i, k in enumerate(pick)
    ]
    adapter = adapter_for(msgtype)
    assert adapter is not None
    assert adapter.fast is not None
    got = adapter.decode(msgs)
    want = _one_by_one(msgtype, msgs)
    assert len(got) == len(want)
    for name in ("t_ns", "xyz", "velocity", "yaw", "track_id", "msg_index"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    assert got.frame_names() == want.frame_names()
    assert got.stamp_fallbacks == want.stamp_fallbacks
    assert got.filtered.get("class", 0) == want.filtered.get("class", 0)
    assert got.n_messages == n


@pytest.mark.parametrize("ros", [1, 2])
@pytest.mark.parametrize("seed", range(4))
def test_a_job_with_damaged_messages_skips_only_them_in_few_decodes(ros: int, seed: int) -> None:
    """Skip mode on a decode job of hundreds of messages with a few truncated ones: the rows,
    counts and first error are those of decoding every message alone, and the job is halved
    down to the bad messages (a few dozen fast decodes, not one per message)."""
    rng = np.random.default_rng(seed)
    good = [
        raw(TRACKED, {"header": {"stamp": {"sec": 5, "nanosec": i}, "frame_id": "map"},
                      "tracks": [{"track_id": i * 10 + k} for k in range(int(rng.integers(0, 4)))]},
            ros, log_time_ns=100 + i)
        for i in range(400)
    ]
    bad_at = set(rng.choice(400, int(rng.integers(1, 4)), replace=False).tolist())
    msgs = [
        RawMessage(m.topic, m.msgtype, m.log_time_ns, m.data[: len(m.data) // 2], m.encoding)
        if i in bad_at else m
        for i, m in enumerate(good)
    ]
    adapter = adapter_for(TRACKED)
    alone = adapter_for(TRACKED)
    assert adapter is not None
    assert alone is not None
    assert adapter.fast is not None
    fast = adapter.fast
    calls = [0]

    def counted(j: Any) -> Any:
        calls[0] += 1
        return fast(j)

    adapter.fast = counted
    got = adapter.decode(msgs, on_error="skip")
    want = FrameDetections.concat([alone.decode([m], on_error="skip") for m in msgs])
    for name in ("t_ns", "xyz", "velocity", "yaw", "track_id", "msg_index"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    assert got.filtered == want.filtered == {"undecodable": len(bad_at)}
    assert adapter.first_error is not None
    assert alone.first_error is not None
    assert adapter.first_error.message == alone.first_error.message
    assert calls[0] <= 1 + 2 * len(bad_at) * 10  # halvings of 400 messages: ~9 levels
