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

from formats.detections import FrameDetections, adapter_for
from formats.raw import RawMessage
from tests.formats.test_detections_fast import (
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
from tests.formats.test_detections_support import raw

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
