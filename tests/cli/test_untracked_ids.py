"""A mapped ``int32 id`` that a detector sets to -1 for "not tracked": no id, so the detections
are linked into tracks, rather than one track of everyone."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import map_cells, run_json
from tests.cli.own_definitions import Message, OwnTypes, write_mcap

S = 1_000_000_000
T0 = 1_700_000_400 * S  # aligned to 600-s windows
TYPES = {
    "dt/msg/D": "int32 id\ngeometry_msgs/Point position\n",
    "dt/msg/Ds": "std_msgs/Header header\ndt/D[] detections\n",
}
MAPPING = (
    '[[topic]]\ntopic = "/detections"\nmsgtype = "dt/msg/Ds"\narray = "detections"\n'
    'position = "position"\nid = "id"\n'
)


def test_id_minus_one_is_no_id_and_the_walkers_are_linked(tmp_path: Path) -> None:
    """Two walkers 5 m apart, one +x and one -x at 1.2 m/s, 20 messages at 2 Hz, both with
    id -1. They were one track of id 2**63-1 (19 'track' headings, all +x, and the -x walker
    none); now each is linked: 20 headings +x (bin 4) and 20 -x (bin 0), the first row of
    each taking its track's first step (the build holds it until the step comes)."""
    own = OwnTypes(TYPES)
    T = own.T
    point = T["geometry_msgs/msg/Point"]
    messages = []
    for k in range(20):
        t = T0 + k * S // 2
        dets = [T["dt/msg/D"](id=-1, position=point(x=0.6 * k, y=1.0, z=0.0)),
                T["dt/msg/D"](id=-1, position=point(x=20 - 0.6 * k, y=6.0, z=0.0))]  # fmt: skip
        msg = T["dt/msg/Ds"](header=own.header(t, "map"), detections=dets)
        messages.append(Message("/detections", "dt/msg/Ds", own.cdr(msg, "dt/msg/Ds"), t))
    log = write_mcap(tmp_path / "dets.mcap", messages,
                     {"dt/msg/Ds": own.definition("dt/msg/Ds")})  # fmt: skip
    mapping = tmp_path / "dets.toml"
    mapping.write_text(MAPPING)
    out = tmp_path / "dets.aion"
    report = run_json("build", log, "-o", out, "--detections-mapping", mapping,
                      "--format", "json")  # fmt: skip
    assert report["detections"] == {"read": 40, "used": 40, "dropped": {}}
    assert report["headings"] == {"velocity": 0, "track": 0, "linked": 40, "pose_yaw": 0,
                                  "none": 0}  # fmt: skip
    assert report["mean_speed_m_s"] == pytest.approx(1.2)
    _, counts, _ = map_cells(out)
    assert counts.sum(axis=0).tolist() == [20, 0, 0, 0, 20, 0, 0, 0]
