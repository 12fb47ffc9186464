"""Long runs: memory stays bounded while streaming, and a build can be resumed with ``--map``.

The multi-GB measurement is ``benchmarks/bench_stream_memory.py`` (on demand); here a 4x longer
log must not need more memory than a 1x log (each built in a subprocess, peak RSS from the
child's own rusage), and continuing a map log by log must equal building from all logs at once.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from tests.robustness.conftest import (
    AION,
    T0,
    Message,
    S,
    aion_env,
    assert_one_error,
    assert_same_arrays,
    build_json,
    graph_payload,
    map_arrays,
    person,
    robot_tf,
    run,
    scene_graph,
    write_log,
)


def peak_rss_of_build(log: Path, out: Path, *options: str) -> int:
    """Peak RSS (bytes) of ``aion build LOG -o OUT`` run in a subprocess."""
    from benchmarks.common import child_usage

    cmd = [str(AION), "build", str(log), "-o", str(out), "-q", *options]
    code, err, usage = child_usage(cmd, env=aion_env())
    assert code == 0, err
    return int(usage.ru_maxrss) * 1024


def test_peak_memory_does_not_grow_with_log_length(tmp_path: Path) -> None:
    """24 MB and 96 MB logs of large TrackedPersons messages (40 people each), read in chunks
    of 100 messages (3.6 MB) so that both logs span many chunks: if the build held the log (or
    anything proportional to it), the 4x build would need 72 MB more."""
    from benchmarks.bench_stream_memory import write_log as write_big

    small, big = tmp_path / "x1.mcap", tmp_path / "x4.mcap"
    n1 = write_big(small, 24 * 2**20)["detections"]
    n4 = write_big(big, 96 * 2**20)["detections"]
    assert n4 >= 4 * n1 - 40
    rss1 = peak_rss_of_build(small, tmp_path / "x1.aion", "--batch-size", "100")
    small.unlink()
    rss4 = peak_rss_of_build(big, tmp_path / "x4.aion", "--batch-size", "100")
    big.unlink()
    print(f"peak RSS: 1x log {rss1 / 2**20:.0f} MB, 4x log {rss4 / 2**20:.0f} MB")
    assert rss4 < 1.5 * rss1, (rss1, rss4)
    assert rss4 - rss1 < 40 * 2**20, (rss1, rss4)


def office_messages(start_s: int, seconds: int) -> list[Message]:
    """TF every 5 s, a scene graph every 60 s, people near p1, p4 and p3 every 2 s."""
    payload = graph_payload()
    out: list[Message] = []
    for k in range(start_s, start_s + seconds):
        t = T0 + k * S
        if k % 60 == 0:
            out.append(scene_graph(t, payload))
        if k % 5 == 0:
            out.append(robot_tf(t))
        if k % 2 == 1:
            spot = [(2.1, 0.1, 0.0), (4.1, 1.9, 0.0), (6.1, -0.1, 0.0)][k % 3]
            out.append(person(t, spot, track=1 + k % 3))
    return out


@pytest.mark.parametrize("cuts_s", [(1500,), (700, 1450, 1950)])
def test_resumed_builds_equal_one_build(cuts_s: tuple[int, ...], tmp_path: Path) -> None:
    """Logs split mid-window (600-s windows): build the first, then ``--map`` each next one;
    every array of the final map equals the map built from all logs at once."""
    total = 2400
    bounds = [0, *cuts_s, total]
    logs = [
        write_log(tmp_path / f"part{i}.mcap", office_messages(a, b - a))
        for i, (a, b) in enumerate(itertools.pairwise(bounds))
    ]
    resumed = tmp_path / "resumed.aion"
    build_json(logs[0], "-o", resumed)
    for log in logs[1:]:
        report = build_json(log, "--map", resumed)
        assert report["continued"]
    once = build_json(*logs, "-o", tmp_path / "once.aion")
    assert once["detections"]["read"] == total // 2
    assert_same_arrays(map_arrays(resumed), map_arrays(tmp_path / "once.aion"))


def test_adding_the_same_log_twice_is_refused(tmp_path: Path) -> None:
    log = write_log(tmp_path / "a.mcap", office_messages(0, 200))
    build_json(log, "-o", tmp_path / "m.aion")
    before = (tmp_path / "m.aion").read_bytes()
    result = run("build", log, "--map", tmp_path / "m.aion")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "already in the map")
    assert (tmp_path / "m.aion").read_bytes() == before
