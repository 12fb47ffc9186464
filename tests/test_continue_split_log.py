"""``aion build B --map build(A)`` where A and B are one recording cut after any of its
messages (people, TF, scene graphs; MCAP or ROS 1 bag), as a property: the continued map is the
map of one build of A and B, member by member (README, "--map OLD continues a map"); with a
robot's TF it is also the map of the uncut log. A fixed sensor's (no TF) is not: its windows
count by the share of them its logs recorded, and the time between A's last message and B's
first is in neither log (``pending_fixed_share`` of the window at the cut)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from aion_cli.build_options import BuildOptions
from aion_cli.pipeline import build_map
from tests.robustness.conftest import (
    T0,
    Message,
    S,
    graph_payload,
    person,
    robot_tf,
    scene_graph,
    write_log,
)
from tests.time_shard_logs import same_maps

SPAN_S = 40 * 60  # four 10-minute windows


def _recording(seed: int, graphs: bool, tf: bool) -> list[Message]:
    """People at random places and times over :data:`SPAN_S`, the robot's TF every 20 s
    (``tf``), a scene graph at the start and one later (``graphs``), in log-time order."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(20, 120))
    times = np.sort(rng.integers(0, SPAN_S, n))
    msgs = [
        person(T0 + int(t) * S + k, (float(rng.uniform(0, 6)), float(rng.uniform(0, 6)), 0.0),
               track=int(rng.integers(1, 5)))
        for k, t in enumerate(times)
    ]
    if tf:
        msgs += [robot_tf(T0 + k * S) for k in range(0, SPAN_S, 20)]
    if graphs:
        msgs += [scene_graph(T0 + 1, graph_payload()),
                 scene_graph(T0 + int(rng.integers(60, SPAN_S)) * S, graph_payload())]
    return sorted(msgs, key=lambda m: m[3])


def _build(out: Path, *logs: Path, continue_from: Path | None = None) -> Path:
    build_map(BuildOptions(logs=logs, output=out, continue_from=continue_from))
    return out


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10**6),
    cut=st.floats(0.0, 1.0),
    graphs=st.booleans(),
    tf=st.booleans(),
    suffix=st.sampled_from([".mcap", ".bag"]),
)
def test_a_recording_cut_after_any_message_and_continued_is_one_build(
    tmp_path_factory: pytest.TempPathFactory,
    seed: int, cut: float, graphs: bool, tf: bool, suffix: str,
) -> None:
    folder = tmp_path_factory.mktemp("cut")
    msgs = _recording(seed, graphs, tf)
    # each part holds people (a log without any is refused) and, with TF, two poses of the
    # robot: a part without TF is a fixed sensor's log, and built alone it stays one (its
    # window a fixed sensor's, which one build of both parts takes for the robot's:
    # docs/ROBUSTNESS.md, "Known weaknesses")
    people = [k for k, m in enumerate(msgs) if m[0] == "/tracks"]
    lo, hi = people[0] + 1, people[-1]
    if tf:
        poses = [k for k, m in enumerate(msgs) if m[0] == "/tf"]
        lo, hi = max(lo, poses[1] + 1), min(hi, poses[-2])
    assume(lo <= hi)
    at = lo + round(cut * (hi - lo))
    container = "mcap" if suffix == ".mcap" else "bag"
    a = write_log(folder / f"a{suffix}", msgs[:at], container)
    b = write_log(folder / f"b{suffix}", msgs[at:], container)
    first = _build(folder / "a.aion", a)
    continued = _build(folder / "b.aion", b, continue_from=first)
    assert same_maps(_build(folder / "ab.aion", a, b), continued) == []
    if tf:
        whole = write_log(folder / f"whole{suffix}", msgs, container)
        assert same_maps(_build(folder / "whole.aion", whole), continued) == []
