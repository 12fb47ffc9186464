"""``aion build --map MAP --graph FILE`` where FILE is a scene graph of another Hydra session
(its place ids p0, p1, ... at other places): accepted without a word before, the continued
map's flows going on by id at unrelated places. Now refused (exit 2, one line and a hint)
unless ``--lineage`` says which: ``different`` releases the map's places to hash cells and
re-binds them to the file's by position (as ``aion merge --lineage different``), ``same``
goes on by id. Known answers from the office log (tests/cli/logdata.py): track 1 stands at
(2.1, 0.1), next to the office graph's p1 at (2, 0)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.mapquery import load_map
from tests.cli.conftest import assert_one_line_error, run, run_json
from tests.cli.logdata import (
    DURATION_S,
    PLACES,
    graph_payload,
    save_graph_file,
    sym,
    write_office_log,
)

#: another session's graph: p1 and p5 swap places, as do p3 and p6 and p0 and p2 (p4 stays)
SWAP = {0: 2, 1: 5, 2: 0, 3: 6, 4: 4, 5: 1, 6: 3}
OTHER = {k: PLACES[SWAP[k]] for k in PLACES}


def place_counts(path: Path) -> dict[int, float]:
    """Detections held per place index (the k of pk) of the map ``path``."""
    state = load_map(path).state
    rows = state.entries.node_rows()
    ids = state.entries.node_id[rows]
    return {
        int(i) - sym("p", 0): float(state.entries.counts[r].sum())
        for i, r in zip(ids, rows, strict=True)
        if state.entries.counts[r].sum() > 0
    }


@pytest.fixture(scope="module")
def continued(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("lineage")
    first = write_office_log(folder / "a.mcap", graph=False, tf=False)
    assert first is not None
    later = folder / "b.mcap"
    write_office_log(later, graph=False, tf=False, shift_s=2 * DURATION_S)
    here = save_graph_file(folder / "here.json")
    other = save_graph_file(folder / "other.json", OTHER)
    m = folder / "m.aion"
    run_json("build", folder / "a.mcap", "--graph", here, "-o", m, "--format", "json")
    return {"map": m, "log": later, "here": here, "other": other, "folder": folder}


def test_another_sessions_graph_is_refused(continued: dict[str, Path]) -> None:
    out = continued["folder"] / "refused.aion"
    result = run(
        "build", continued["log"], "--map", continued["map"], "--graph", continued["other"],
        "-o", out,
    )  # fmt: skip
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(
        result.stderr, "other.json is a scene graph of another session than m.aion's",
        "of the 7 place ids both hold, 1 lie within 1 m",
    )
    assert "--lineage different" in result.stderr
    assert "--lineage same" in result.stderr
    assert not out.exists()


def test_the_maps_own_graph_goes_on(continued: dict[str, Path]) -> None:
    out = continued["folder"] / "same.aion"
    report = run_json(
        "build", continued["log"], "--map", continued["map"], "--graph", continued["here"],
        "-o", out, "--format", "json",
    )  # fmt: skip
    assert report["continued"] is True
    counts = place_counts(out)
    assert counts[1] > 0  # track 1 on p1 at (2, 0)
    assert 5 not in counts  # nobody at (20, 0)


def test_lineage_different_rebinds_by_position_and_same_goes_on_by_id(
    continued: dict[str, Path],
) -> None:
    """The same log continued on the map's own graph and on the other session's: with
    --lineage different every place holds what the same place holds on the map's own graph
    (track 1's detections on p5, at (2, 0) in the other session); with --lineage same p1 keeps
    the first log's detections by id, at (20, 0), where nobody walked."""
    folder = continued["folder"]
    same_graph = folder / "own.aion"
    run_json(
        "build", continued["log"], "--map", continued["map"], "--graph", continued["here"],
        "-o", same_graph, "--format", "json",
    )  # fmt: skip
    expected = {SWAP[k]: n for k, n in place_counts(same_graph).items()}
    moved = folder / "different.aion"
    report = run_json(
        "build", continued["log"], "--map", continued["map"], "--graph", continued["other"],
        "-o", moved, "--lineage", "different", "--format", "json",
    )  # fmt: skip
    assert any("--lineage different: m.aion's" in n for n in report["notes"]), report["notes"]
    got = place_counts(moved)
    assert got.keys() == expected.keys()
    np.testing.assert_allclose([got[k] for k in sorted(got)], [expected[k] for k in sorted(got)])
    by_id = folder / "by-id.aion"
    run_json(
        "build", continued["log"], "--map", continued["map"], "--graph", continued["other"],
        "-o", by_id, "--lineage", "same", "--format", "json",
    )  # fmt: skip
    assert place_counts(by_id).get(1, 0) > 0  # the first log's track 1, now at (20, 0)


# --- the logs' own scene graphs (no --graph FILE): the first one the build applies or peeks

#: the map's own session later: p6 moved 0.4 m, a place p7 added
LATER = {**PLACES, 6: (22.4, 0.0, 0.0), 7: (10.0, 0.0, 0.0)}


@pytest.fixture(scope="module")
def from_logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A map of the office log with its own scene graphs, and three later logs: another
    session's graphs (:data:`SWAP`), the same session's with places moved and added, and the
    office's own (the known answer for ``--lineage different``, mapped by :data:`SWAP`)."""
    folder = tmp_path_factory.mktemp("lineage-logs")
    write_office_log(folder / "a.mcap", tf=False)
    later = {"other": OTHER, "moved": LATER, "own": PLACES}
    paths = {k: folder / f"b-{k}.mcap" for k in later}
    for k, places in later.items():
        write_office_log(paths[k], tf=False, shift_s=2 * DURATION_S, places=places)
        # a log after it: the two are built in parallel with --workers 2
        write_office_log(folder / f"c-{k}.mcap", tf=False, shift_s=4 * DURATION_S, places=places)
    m = folder / "m.aion"
    run_json("build", folder / "a.mcap", "-o", m, "--workers", "1", "--format", "json")
    return {"map": m, "folder": folder, **paths}


def logs(from_logs: dict[str, Path], kind: str, workers: str) -> list[Path]:
    """The later log of ``kind``; with two workers, also the one after it (two shards)."""
    first = from_logs[kind]
    return [first] if workers == "1" else [first, first.with_name(f"c-{kind}.mcap")]


@pytest.mark.parametrize("workers", ["1", "2"])
def test_another_sessions_graphs_in_the_log_are_refused(
    from_logs: dict[str, Path], workers: str
) -> None:
    """Sequential (checked when the first graph is applied) and parallel (two logs, two
    shards: peeked by the parent, whose shards do not see the map) alike."""
    out = from_logs["folder"] / f"refused-{workers}.aion"
    result = run(
        "build", *logs(from_logs, "other", workers), "--map", from_logs["map"], "-o", out,
        "--workers", workers,
    )  # fmt: skip
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(
        result.stderr, "the scene graph in b-other.mcap", "is of another session than m.aion's",
        "of the 7 place ids both hold, 1 lie within 1 m",
    )
    assert "--lineage different" in result.stderr
    assert "--lineage same" in result.stderr
    assert not out.exists()


def test_the_maps_own_session_in_the_log_goes_on(from_logs: dict[str, Path]) -> None:
    """A later log of the map's own session (p6 moved 0.4 m, p7 added) is not refused."""
    out = from_logs["folder"] / "moved.aion"
    report = run_json(
        "build", from_logs["moved"], "--map", from_logs["map"], "-o", out, "--format", "json",
    )  # fmt: skip
    assert report["continued"] is True
    assert not any("lineage" in n for n in report["notes"]), report["notes"]
    counts = place_counts(out)
    assert counts[1] > 0  # track 1 on p1 at (2, 0)
    assert 5 not in counts  # nobody at (20, 0)


@pytest.mark.parametrize("workers", ["1", "2"])
def test_lineage_of_the_logs_graphs_different_rebinds_and_same_goes_on_by_id(
    from_logs: dict[str, Path], workers: str
) -> None:
    """As with --graph FILE: --lineage different gives every place what the same place holds
    when the later log has the map's own graphs (track 1's detections on p5, at (2, 0) in the
    other session); --lineage same keeps p1's first-log detections by id, at (20, 0)."""
    folder = from_logs["folder"]
    own = folder / f"own-{workers}.aion"
    parallel = run_json(
        "build", *logs(from_logs, "own", workers), "--map", from_logs["map"], "-o", own,
        "--workers", workers, "--format", "json",
    )  # fmt: skip
    assert len(parallel["workers"]) == (0 if workers == "1" else 2)  # per shard, in parallel
    expected = {SWAP[k]: n for k, n in place_counts(own).items()}
    moved = folder / f"different-{workers}.aion"
    report = run_json(
        "build", *logs(from_logs, "other", workers), "--map", from_logs["map"], "-o", moved,
        "--lineage", "different", "--workers", workers, "--format", "json",
    )  # fmt: skip
    assert any("--lineage different: m.aion's" in n for n in report["notes"]), report["notes"]
    got = place_counts(moved)
    assert got.keys() == expected.keys()
    np.testing.assert_allclose([got[k] for k in sorted(got)], [expected[k] for k in sorted(got)])
    by_id = folder / f"by-id-{workers}.aion"
    run_json(
        "build", *logs(from_logs, "other", workers), "--map", from_logs["map"], "-o", by_id,
        "--lineage", "same", "--workers", workers, "--format", "json",
    )  # fmt: skip
    assert place_counts(by_id).get(1, 0) > 0  # the first log's track 1, now at (20, 0)


def test_the_api_checks_the_logs_graphs_too(from_logs: dict[str, Path]) -> None:
    import aion_cli as aion
    from aion_cli.errors import InputError

    out = from_logs["folder"] / "api.aion"
    with pytest.raises(InputError, match=r"another session than m\.aion's"):
        aion.build([from_logs["other"]], out, continue_from=from_logs["map"])
    aion.build([from_logs["other"]], out, continue_from=from_logs["map"], lineage="same")
    assert place_counts(out).get(1, 0) > 0


@pytest.mark.parametrize("workers", ["1", "2"])
@pytest.mark.parametrize("kind", ["own", "other"])
def test_a_stray_first_graph_decides_nothing(
    from_logs: dict[str, Path], kind: str, workers: str
) -> None:
    """The later logs' first DsgUpdate is logged two days before the rest (a stray log time,
    which the build drops) and holds the other session's places. The parent of a parallel
    build peeked at that message, not at the first graph the build applies: a stray of another
    session before the map's own graphs refused the build, and a stray of the map's own
    session before another session's graphs let it through (flows on unrelated places), while
    the sequential build decided on the graphs it uses. Both decide on those now."""
    folder = from_logs["folder"]
    later = folder / f"stray-{kind}.mcap"
    if not later.exists():
        stray = graph_payload(OTHER if kind == "own" else PLACES)
        write_office_log(
            later, tf=False, shift_s=2 * DURATION_S, places=OTHER if kind == "other" else None,
            early_graph=(2 * 86_400, stray),
        )  # fmt: skip
    out = folder / f"stray-{kind}-{workers}.aion"
    given = [later] if workers == "1" else [later, folder / f"c-{kind}.mcap"]
    result = run("build", *given, "--map", from_logs["map"], "-o", out, "--workers", workers)
    if kind == "other":
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(
            result.stderr, f"the scene graph in stray-{kind}.mcap",
            "is of another session than m.aion's", "of the 7 place ids both hold, 1 lie within",
        )  # fmt: skip
        assert not out.exists()
        return
    assert result.exit_code == 0, result.stderr
    assert "log time more than a day away" in result.stderr  # the stray was dropped
    counts = place_counts(out)
    assert counts[1] > 0  # track 1 on p1 at (2, 0)
    assert 5 not in counts  # nobody at (20, 0)
