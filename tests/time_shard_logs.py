"""Logs and builds shared by the time-shard tests (``tests/test_time_shards*.py``): the
sequential and parallel builds of the same logs, compared as saved maps
(:func:`aion_cli.engine.compare.differences`: ints exact, floats 1e-12) and as reports."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.compare import differences
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import T0, S

HOUR_S = 3600
W = 600 * S  # the default window
# Monday 08:00 (the log's first session), Monday 18:00, Wednesday 08:00, Thursday 10:00
LATER_S = (10 * HOUR_S, 48 * HOUR_S, 74 * HOUR_S)


def build_logs(logs: list[Path], out: Path, workers: int, **kw: object) -> Any:
    """``aion build`` of ``logs`` into ``out`` (replaced) with ``workers`` processes."""
    out.unlink(missing_ok=True)
    return build_map(BuildOptions(logs=tuple(logs), output=out, workers=workers, **kw))  # type: ignore[arg-type]


def build_on_local_cluster(logs: list[Path], out: Path) -> Any:
    """:func:`build_logs` with ``--scheduler`` on a real local Dask cluster (two worker
    processes, localhost only); the test is skipped without the ``dask`` extra."""
    import pytest

    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
        # the scheduler's HTTP server on a free port, not on 8787 (taken: a warning)
        scheduler_kwargs={"dashboard_address": ":0"},
        host="127.0.0.1",
    ) as cluster:
        return build_logs(logs, out, 1, scheduler=cluster.scheduler_address)


def same_maps(a: Path, b: Path) -> list[str]:
    """What differs between the two saved maps (empty: the same map)."""
    return differences(load_map(a, writable=True).state, load_map(b, writable=True).state)


def same_reports(one: object, two: object) -> None:
    """The counts two builds report are equal."""
    a, b = one.to_dict(), two.to_dict()  # type: ignore[attr-defined]
    for key in ("detections", "detections_by_topic", "headings", "observation", "time_span"):
        assert a[key] == b[key], key
    assert a["graph"]["messages"] == b["graph"]["messages"]


def second_part_in_sequence(tmp_path: Path, log: Path, why: str) -> tuple[Any, Any]:
    """The sequential and the 2-worker build of ``log``: two time shards, the second learnt
    in sequence onto the first for ``why`` (a note says so), the map of one pass."""
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = build_logs([log], seq, 1)
    two = build_logs([log], par, 2)
    assert len(two.workers) == 2
    notes = [n for n in two.notes if "in sequence" in n]
    assert len(notes) == 1
    assert why in notes[0]
    assert same_maps(seq, par) == []
    return one, two


def standing_log(path: Path, sessions: list[tuple[int, list[float]]]) -> Path:
    """People standing still (no velocity) whose poses carry a yaw: per session (start
    seconds after T0, one yaw per person), a message every 10 s for 20 minutes."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path) as writer:
        for start_s, yaws in sessions:
            for k in range(120):
                t = T0 + (start_s + 5 + 10 * k) * S
                tracks = [
                    {
                        "track_id": i + 1,
                        "is_matched": True,
                        "pose": {"pose": {
                            "position": {"x": 2.0 + 2 * i, "y": 0.5, "z": 0.0},
                            "orientation": {"z": np.sin(yaw / 2), "w": np.cos(yaw / 2)},
                        }},
                        "twist": {"twist": {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}}},
                    }
                    for i, yaw in enumerate(yaws)
                ]
                stamp = {"sec": t // S, "nanosec": t % S}
                writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons",
                             {"header": {"stamp": stamp, "frame_id": "map"}, "tracks": tracks}, t)
    return path
