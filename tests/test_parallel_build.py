"""``aion build --workers N`` / ``--scheduler``: the map of the sequential build, from shards.

Every comparison is :func:`aion_cli.engine.compare.differences` of the two maps as saved
(ints exact, floats 1e-12), on logs with known contents (``tests/cli/logdata.py``): a robot
at a fixed pose (TF), people at fixed spots, the office graph in every ``DsgUpdate``.
"""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from aion_cli.engine.compare import differences
from aion_cli.errors import InputError
from aion_cli.mapquery import load_map
from aion_cli.parallel_build import plan_shards
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import write_office_log
from tests.time_shard_logs import build_on_local_cluster

HOUR_S = 3600
DAY_S = 86_400
W = 600 * 10**9


def _logs(folder: Path, shifts_h: list[float], graph: list[bool] | None = None) -> list[Path]:
    """Office logs of two hours each, starting ``shifts_h`` hours after Monday 08:00."""
    paths = []
    for k, shift in enumerate(shifts_h):
        path = folder / f"day{k}.mcap"
        with_graph = True if graph is None else graph[k]
        write_office_log(path, shift_s=int(shift * HOUR_S), duration_s=2 * HOUR_S, graph=with_graph)
        paths.append(path)
    return paths


def _build(logs: list[Path], out: Path, workers: int, **kw: object) -> object:
    out.unlink(missing_ok=True)
    return build_map(BuildOptions(logs=tuple(logs), output=out, workers=workers, **kw))  # type: ignore[arg-type]


def _same_maps(a: Path, b: Path) -> list[str]:
    return differences(load_map(a, writable=True).state, load_map(b, writable=True).state)


def test_plan_shards_groups_logs_that_share_a_window_or_touch() -> None:
    p = [Path(f"l{k}") for k in range(6)]
    spans = [
        (p[3], 50 * W, 51 * W),  # given out of order
        (p[0], 0, 2 * W + 5),
        (p[1], 2 * W + 100, 3 * W),  # starts in the window in which l0 ends: together
        (p[2], 10 * W, 11 * W - 1),
        (p[4], 11 * W + 3 * 10**9, 12 * W),  # 3 s after l2 (a new window, but touching)
        (p[5], 30 * W, 31 * W),
    ]
    assert plan_shards(spans, W) == [(p[0], p[1]), (p[2], p[4]), (p[5],), (p[3],)]


def test_workers_build_the_sequential_map(tmp_path: Path) -> None:
    # Monday, Monday evening (the same day), Wednesday, Thursday: three shards, four logs
    logs = _logs(tmp_path, [0, 10, 2 * 24, 3 * 24 + 2])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = _build(logs, seq, 1)
    two = _build(logs, par, 2)
    assert _same_maps(seq, par) == []
    assert len(two.workers) == 4  # type: ignore[attr-defined]
    assert not [n for n in two.notes if "in sequence" in n]  # type: ignore[attr-defined]
    for key in ("detections", "detections_by_topic", "headings", "observation", "time_span"):
        assert two.to_dict()[key] == one.to_dict()[key], key  # type: ignore[attr-defined]
    assert one.to_dict()["workers"] == []  # type: ignore[attr-defined]
    state = load_map(par).state
    assert state.temporal.flow_scored.sum() > 0  # later days were scored at the joins


def test_workers_continue_a_map_like_the_sequential_build(tmp_path: Path) -> None:
    first, *rest = _logs(tmp_path, [0, 24, 2 * 24, 4 * 24])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build([first], seq, 1)
    _build([first], par, 1)
    build_map(BuildOptions(logs=tuple(rest), output=seq, continue_from=seq, workers=1))
    report = build_map(BuildOptions(logs=tuple(rest), output=par, continue_from=par, workers=2))
    assert len(report.workers) == 3
    assert _same_maps(seq, par) == []


def test_a_shard_that_cannot_be_joined_exactly_is_learnt_in_sequence(tmp_path: Path) -> None:
    # the second log has no scene graph: one pass keeps using the first log's graph
    logs = _logs(tmp_path, [0, 24, 48], graph=[True, False, True])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build(logs, seq, 1)
    report = _build(logs, par, 2)
    notes = [n for n in report.notes if "in sequence" in n]  # type: ignore[attr-defined]
    assert len(notes) == 1
    assert "day1.mcap" in notes[0]
    assert "no scene graph" in notes[0]
    assert _same_maps(seq, par) == []


def test_overlapping_logs_are_one_shard_built_in_sequence(tmp_path: Path) -> None:
    logs = _logs(tmp_path, [0, 1])  # two-hour logs one hour apart
    report = _build(logs, tmp_path / "par.aion", 2)
    assert report.workers == []  # type: ignore[attr-defined]
    assert any("overlap in time" in n for n in report.notes)  # type: ignore[attr-defined]


def test_one_log_without_a_quiet_moment_is_built_in_one_process_and_says_so(
    tmp_path: Path,
) -> None:
    # people every 10 s from start to end: no window start has 10 s without a detection
    # message before it, so the log cannot be cut into time shards (tests/test_time_shards.py)
    (log,) = _logs(tmp_path, [0])
    report = _build([log], tmp_path / "par.aion", 2)
    assert report.workers == []  # type: ignore[attr-defined]
    assert any(
        "one log: built in sequence" in n and "no quiet moment" in n
        for n in report.notes  # type: ignore[attr-defined]
    )
    quiet = _build([log], tmp_path / "seq.aion", 1)  # not asked for workers: no note
    assert not any("one log" in n for n in quiet.notes)  # type: ignore[attr-defined]
    default = _build([log], tmp_path / "default.aion", 0)  # one per core, unasked: no note
    assert not any("one log" in n for n in default.notes)  # type: ignore[attr-defined]


def test_a_log_out_of_time_order_fails_and_leaves_the_map(tmp_path: Path) -> None:
    early, late, later = _logs(tmp_path, [0, 48, 72])
    out = tmp_path / "map.aion"
    _build([late], out, 1)
    before = hashlib.sha256(out.read_bytes()).hexdigest()
    for workers in (1, 2):
        with pytest.raises(InputError, match="time order"):
            build_map(
                BuildOptions(logs=(early, later), output=out, continue_from=out, workers=workers)
            )
        assert hashlib.sha256(out.read_bytes()).hexdigest() == before


def test_bad_worker_counts_are_refused(tmp_path: Path) -> None:
    logs = _logs(tmp_path, [0, 48])
    with pytest.raises(InputError, match="--workers"):
        _build(logs, tmp_path / "m.aion", -1)


@pytest.mark.slow
def test_shards_whose_scene_graph_changed_are_named_with_a_hint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Two simulated Hydra sessions of the office (their graphs grow and are corrected at loop
    # closures): the second session's shard binds cells to the places of its own time, where
    # one pass kept the first session's bindings. The fold learns it again in sequence (the
    # map of one pass) and the report says so once, with the way round it.
    # (The planner keeps sessions whose first graph lacks places of the one before together
    # (test below); the fold's fallback stays for what it cannot see: told none here.)
    import aion_cli.shard_graphs as shard_graphs

    monkeypatch.setattr(shard_graphs, "graph_breaks", _no_breaks)
    logs = _sessions(tmp_path, ("2026-01-05", "2026-01-07"))
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build(logs, seq, 1)
    report = _build(logs, par, 2)
    assert _same_maps(seq, par) == []
    notes = report.notes  # type: ignore[attr-defined]
    assert [n for n in notes if "session1.mcap was learnt in sequence" in n]
    hints = [n for n in notes if "built twice" in n]
    assert hints == [
        "1 of 2 shards was built twice (in a worker, then in sequence) because of cells bound "
        "to other places than the map before them, which a shard built apart cannot know; for "
        "logs whose scene graph changes as they go (a live Hydra stream) --workers 1 is faster "
        "(docs/SCALING.md)"
    ]


def _no_breaks(groups: list[Any], *_: Any) -> list[bool]:
    """``shard_graphs.graph_breaks`` telling no session boundary (the fold's fallback is
    then what these tests see)."""
    return [False] * (len(groups) - 1)


def _sessions(tmp_path: Path, starts: tuple[str, ...]) -> list[Path]:
    """Simulated Hydra sessions of the office (half a day each, their graphs growing and
    corrected at loop closures), one log per start date."""
    logs = []
    for k, start in enumerate(starts):
        log = tmp_path / f"session{k}.mcap"
        subprocess.run(
            [sys.executable, "-m", "aion_cli", "simulate", "-o", str(log), "--days", "0.5",
             "--seed", str(k + 1), "--start", start, "-q"],
            check=True,
        )
        logs.append(log)
    return logs


@pytest.mark.slow
@pytest.mark.skipif(sys.platform != "linux", reason="the workers are forked with the patch")
def test_after_a_graph_change_the_rest_is_learnt_in_sequence_without_the_workers(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Three sessions, two workers: the second session's shard falls back (its graph bound
    # cells otherwise than one pass), so the third's graph changes too. The workers are then
    # stopped and the third is learnt in sequence at once: the worker that took it (slowed
    # here to a minute, then leaving a mark) never finishes it. The map is one pass's.
    import aion_cli.process_pool as pool
    import aion_cli.shard_graphs as shard_graphs

    # (the planner told no session boundary, as in the test above)
    monkeypatch.setattr(shard_graphs, "graph_breaks", _no_breaks)
    logs = _sessions(tmp_path, ("2026-01-05", "2026-01-07", "2026-01-09"))
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build(logs, seq, 1)
    mark = tmp_path / "third-shard-built-by-a-worker"
    real = pool.build_shard

    def slow_third(task: Any, sink: Any) -> Any:
        if task.index >= 2:
            time.sleep(60)
            mark.touch()
        return real(task, sink)

    monkeypatch.setattr(pool, "build_shard", slow_third)
    report = _build(logs, par, 2)
    assert not mark.exists()
    _assert_the_rest_was_learnt_in_sequence(seq, par, report)
    assert [n for n in report.notes if n.startswith("1 of 3 shards was built twice")]  # type: ignore[attr-defined]


def _assert_the_rest_was_learnt_in_sequence(seq: Path, par: Path, report: Any) -> None:
    """Three sessions, the second's shard learnt again: one pass's map, the third shard
    learnt in sequence without a worker's build, only shards 0 and 1 built by workers."""
    assert _same_maps(seq, par) == []
    notes = report.notes
    assert [n for n in notes if "session1.mcap was learnt in sequence" in n]
    assert (
        "the scene graph changed between shards: the last 1 of 3 shards was learnt in "
        "sequence without waiting for the workers (its graph would have changed too)"
    ) in notes
    assert [row["shard"] for row in report.workers] == [0, 1]


@pytest.mark.slow
def test_sessions_whose_first_graph_lost_places_are_built_in_sequence_from_the_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Three simulated sessions: each starts exploring again with a graph of its own, which
    # lacks the places of the session before. The planner sees it in their first and last
    # graphs and builds them in sequence at once: no worker builds a shard only for its join
    # to be refused. The map is one pass's, and the note names the sessions.
    import aion_cli.process_pool as pool

    logs = _sessions(tmp_path, ("2026-01-05", "2026-01-07", "2026-01-09"))
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build(logs, seq, 1)

    def no_workers(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("a worker pool was started")

    monkeypatch.setattr(pool, "run_in_processes", no_workers)
    report = _build(logs, par, 2)
    assert _same_maps(seq, par) == []
    notes = report.notes  # type: ignore[attr-defined]
    assert [n for n in notes if n.startswith("session1.mcap, session2.mcap: their first scene")]
    assert not [n for n in notes if "learnt in sequence" in n]
    assert not [n for n in notes if "time shards" in n or "no quiet moment" in n]  # one note
    assert report.workers == []  # type: ignore[attr-defined]


@pytest.mark.skipif(not hasattr(signal, "SIGTERM") or sys.platform != "linux", reason="fork")
def test_a_stopped_worker_ends_quietly(
    capfd: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # The CLI turns SIGTERM into KeyboardInterrupt (so its map file is cleaned up), and a
    # forked worker inherits that handler: when the parent stopped the workers after an error
    # or Ctrl-C, each printed a KeyboardInterrupt traceback under the one-line error.
    import multiprocessing as mp

    import aion_cli.process_pool as pool
    from aion_cli.cli.main import _terminated

    ctx = mp.get_context("fork")
    building = ctx.Event()

    def build_shard(task: object, sink: object) -> None:
        building.set()
        time.sleep(60)

    monkeypatch.setattr(pool, "build_shard", build_shard)
    tasks, out = [SimpleNamespace(index=0)], ctx.Queue()
    previous = signal.signal(signal.SIGTERM, _terminated)
    try:
        worker = ctx.Process(
            target=pool._worker, args=(tasks, ctx.Value("q", 0), out), daemon=True
        )
        worker.start()
    finally:
        signal.signal(signal.SIGTERM, previous)
    # the worker is building its shard (0.3 s of sleep was not always enough on a busy machine:
    # stopped before its handler was reset, it printed the KeyboardInterrupt this test forbids)
    assert building.wait(timeout=60), "the worker did not start its shard"
    worker.terminate()
    worker.join(timeout=10)
    err = capfd.readouterr().err
    assert worker.exitcode == -signal.SIGTERM
    assert "Traceback" not in err
    assert "KeyboardInterrupt" not in err


@pytest.mark.skipif(sys.platform != "linux", reason="workers fork only on Linux")
def test_workers_fork_beside_the_log_hashing_thread_only(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The build hashes its logs in a thread while it learns; a parallel build that found it
    # still running started its workers from a forkserver (a fresh process importing the
    # build's modules), slower, and only when the hash had not finished: a race. The threads
    # the choice sees are given here: a thread another test left finishing in the background
    # must not decide this test (it did, once).
    import threading

    from aion_cli.process_pool import _context

    main = threading.main_thread()
    release = threading.Event()
    for names, method in (
        ((), "fork"),
        (("aion-hash-logs",), "fork"),
        (("progress-refresh",), "forkserver"),
        (("aion-hash-logs", "progress-refresh"), "forkserver"),
    ):
        threads = [threading.Thread(target=release.wait, name=n, daemon=True) for n in names]
        for thread in threads:
            thread.start()
        monkeypatch.setattr(threading, "enumerate", lambda ts=threads: [main, *ts])
        try:
            assert _context().get_start_method() == method, names
        finally:
            monkeypatch.undo()
            release.set()
            for thread in threads:
                thread.join()
            release.clear()


@pytest.mark.slow
def test_a_dask_cluster_builds_the_sequential_map(tmp_path: Path) -> None:
    logs = _logs(tmp_path, [0, 24, 2 * 24, 3 * 24 + 2])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build(logs, seq, 1)
    report = build_on_local_cluster(logs, par)
    workers = {w["worker"] for w in report.workers}
    assert len(report.workers) == 4  # type: ignore[attr-defined]
    assert workers  # the cluster's worker processes built them, never this one
    assert all(w.split(":")[-1] != str(os.getpid()) for w in workers)
    assert _same_maps(seq, par) == []


@pytest.mark.slow
def test_on_a_dask_cluster_the_rest_after_a_graph_change_is_learnt_in_sequence(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The three Hydra sessions of the local pool's test above, on a cluster: the second
    # session's fold learns it again (its graph bound cells otherwise than one pass), so the
    # third's build is cancelled and it is learnt in sequence as one task. The map is one
    # pass's; the workers' rows list the shards they built and the fold used.
    import aion_cli.shard_graphs as shard_graphs

    monkeypatch.setattr(shard_graphs, "graph_breaks", _no_breaks)  # the planner, here
    logs = _sessions(tmp_path, ("2026-01-05", "2026-01-07", "2026-01-09"))
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build(logs, seq, 1)
    _assert_the_rest_was_learnt_in_sequence(seq, par, build_on_local_cluster(logs, par))


def test_a_scheduler_not_needed_is_said_not_silently_ignored(tmp_path: Path) -> None:
    """One log of two hours has no quiet moment to cut it at: it is one shard and runs here,
    and the report says the scheduler (unreachable: a contact would fail) was not used."""
    (log,) = _logs(tmp_path, [0])
    report = _build([log], tmp_path / "m.aion", 1, scheduler="tcp://127.0.0.1:9")
    notes = report.notes  # type: ignore[attr-defined]
    assert any(n.startswith("--scheduler tcp://127.0.0.1:9: not contacted") for n in notes)
    assert any("built in sequence, not in parallel" in n for n in notes)


def test_a_hydra_session_across_logs_joins_as_one_pass(tmp_path: Path) -> None:
    # two recordings of one Hydra session, three hours apart, the robot's poses from the
    # graphs' agent layer: every graph repeats the session's trajectory from its start, so the
    # second log's graphs hold the first's poses again (one pass fed them with the first log's
    # graphs). Its shard feeds only its own; the join closes the earlier map's windows those
    # poses cover up to the shard's first, as the shard's first message does in one pass.
    first, second = tmp_path / "a.mcap", tmp_path / "b.mcap"
    write_office_log(first, tf=False, agents=True, duration_s=2 * HOUR_S)
    write_office_log(second, tf=False, agents=True, duration_s=2 * HOUR_S,
                     shift_s=3 * HOUR_S, agents_since_s=0)
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = _build([first, second], seq, 1)
    two = _build([first, second], par, 2)
    assert len(two.workers) == 2  # type: ignore[attr-defined]
    assert one.observation == two.observation == "scene-graph agent layer"  # type: ignore[attr-defined]
    assert not [n for n in two.notes if "in sequence" in n]  # type: ignore[attr-defined]
    assert _same_maps(seq, par) == []
