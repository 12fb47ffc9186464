"""Times that cannot belong together (:mod:`aion_cli.times_apart`): ``aion build --observed``
and ``aion convert --observed`` spans apart from the logs' messages, and a scene graph's agent
layer whose robot poses lie apart from the log's time, are warned of; their legitimate
neighbours (a span overlapping the logs by one window, a span a day beyond them, agent poses
inside the log's time) are not."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats import dsg as fdsg
from aion_cli.formats.writers import LogWriter
from aion_cli.times_apart import FAR_NS, span_apart
from tests.cli.conftest import Office, run
from tests.shared_data import real

S = 10**9
DAY = 86_400 * S
T0 = 1_767_607_200 * S  # 2026-01-05 10:00 UTC (a Monday)


def _write_log(path: Path, t0: int, graph: Path | None = None, seconds: int = 3600) -> Path:
    """A fixed sensor's log without TF: one person at (1, 2) every 10 s for ``seconds`` from
    ``t0``, and (``graph``) that graph file's payload every 600 s as Hydra's DsgUpdate."""
    payload = None if graph is None else bytes(fdsg.read_dsg_file(graph).graph.to_binary(True))
    with LogWriter(path, "mcap") as writer:
        for s in range(0, seconds, 10):
            t = t0 + s * S
            if payload is not None and s % 600 == 0:
                writer.write(
                    "/hydra/backend/dsg", "hydra_msgs/msg/DsgUpdate",
                    {"header": {"stamp": {"sec": t // S}, "frame_id": "map"},
                     "layer_contents": np.frombuffer(payload, np.uint8), "full_update": True},
                    t,
                )  # fmt: skip
            track = {"track_id": 1, "is_matched": True, "pose": {"pose": {
                "position": {"x": 1.0, "y": 2.0, "z": 0.0}, "orientation": {"w": 1.0}}}}
            writer.write(
                "/tracks", "spencer_tracking_msgs/msg/TrackedPersons",
                {"header": {"stamp": {"sec": t // S}, "frame_id": "map"}, "tracks": [track]}, t,
            )  # fmt: skip
    return path


def test_span_apart_rule() -> None:
    """Hand-placed spans against messages 10:00 .. 10:59:50 (one hour)."""
    first, last = T0, T0 + 3590 * S
    assert span_apart(T0 - 3600 * S, T0, first, last) == "lies wholly before"  # ends at first
    assert span_apart(last + S, last + 2 * S, first, last) == "lies wholly after"
    assert span_apart(T0 - 600 * S, T0 + 1, first, last) is None  # overlaps by 1 ns
    assert span_apart(T0 - FAR_NS, last, first, last) is None  # a week before: not more
    assert span_apart(T0 - FAR_NS - S, last, first, last) == "reaches 7.0 days beyond"
    # logs spanning 30 days: 20 days beyond them is within their own span
    assert span_apart(T0 - 20 * DAY, T0 + 30 * DAY, T0, T0 + 30 * DAY) is None
    assert span_apart(T0 - 31 * DAY, T0 + 30 * DAY, T0, T0 + 30 * DAY) == (
        "reaches 31.0 days beyond"
    )


@pytest.mark.parametrize(
    ("span", "how"),
    [
        ("2016-01-05 10:00..2016-01-05 12:00", "lies wholly before"),  # year mistyped
        ("2026-01-05 12:00..2026-01-05 13:00", "lies wholly after"),  # an hour after the last
        ("2016-01-05 10:00..2026-01-05 12:00", "reaches 3,653.0 days beyond"),  # reaching back
        ("1767607..1767610", "lies wholly before"),  # UNIX seconds with 3 digits lost: 1970-01-21
    ],
)
def test_build_warns_of_a_span_apart(tmp_path: Path, span: str, how: str) -> None:
    log = _write_log(tmp_path / "a.mcap", T0)
    result = run("build", log, "-o", tmp_path / "a.aion", "--observed", span, "-q")
    assert result.exit_code == 0, result.stderr  # a warning: the map is built as declared
    warned = [line for line in result.stderr.splitlines() if line.startswith("warning: --obs")]
    assert len(warned) == 1, result.stderr
    assert f'--observed "{span}"' in warned[0]  # as typed
    assert f"{how} the logs' messages (2026-01-05 10:00:00+00:00 .. 2026-01-05 10:59:50+00:00)" \
        in warned[0]
    assert "hint:" in warned[0]


@pytest.mark.parametrize(
    "span",
    [
        "2026-01-05 09:00..2026-01-05 10:10",  # overlaps the logs by one window
        "2026-01-05 10:50..2026-01-06 10:00",  # reaches a day after them
        "2026-01-05 10:00..2026-01-05 11:00",  # the logs' own hour
    ],
)
def test_build_quiet_for_a_span_beside_the_logs(tmp_path: Path, span: str) -> None:
    log = _write_log(tmp_path / "a.mcap", T0)
    result = run("build", log, "-o", tmp_path / "a.aion", "--observed", span, "-q")
    assert result.exit_code == 0, result.stderr
    assert "--observed" not in result.stderr, result.stderr


def test_parallel_build_checks_all_logs_at_once(tmp_path: Path) -> None:
    """Two logs a day apart built by two workers: one warning against both logs' time (not
    one per shard), and a span reaching from the first log into the second is quiet."""
    logs = [_write_log(tmp_path / f"{d}.mcap", T0 + d * DAY) for d in (0, 1)]
    result = run(
        "build", *logs, "-o", tmp_path / "a.aion", "--workers", "2", "-q",
        "--observed", "2016-01-05 10:00..2016-01-05 12:00",
        "--observed", "2026-01-05 10:30..2026-01-06 10:30",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    warned = [line for line in result.stderr.splitlines() if line.startswith("warning: --obs")]
    assert len(warned) == 1, result.stderr
    assert '"2016-01-05 10:00..2016-01-05 12:00"' in warned[0]
    assert "(2026-01-05 10:00:00+00:00 .. 2026-01-06 10:59:50+00:00)" in warned[0]


def test_convert_names_a_span_apart_in_its_zone(tmp_path: Path) -> None:
    """A span typed with the year 2016 for 2026, and one overlapping the detections."""
    csv = tmp_path / "t.csv"
    rows = [f"{T0 + k * S},1,{k * 0.1:.1f},0.0,0.0,0.0,1.0" for k in range(60)]
    csv.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n" + "\n".join(rows) + "\n")
    result = run(
        "convert", csv, "-o", tmp_path / "c.mcap", "--tz", "Europe/Berlin",
        "--observed", "2016-01-05 11:00..2016-01-05 12:00",
        "--observed", "2026-01-05 10:00..2026-01-05 11:01",
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    warned = [line for line in result.stderr.splitlines() if line.startswith("warning: --obs")]
    assert warned == [
        next(line for line in result.stderr.splitlines() if "2016-01-05 11:00..2016" in line)
    ]
    assert (
        '--observed "2016-01-05 11:00..2016-01-05 12:00" (2016-01-05 11:00:00+01:00 .. '
        "2016-01-05 12:00:00+01:00) lies wholly before the detections (2026-01-05 "
        "11:00:00+01:00 .. 2026-01-05 11:00:59+01:00)"
    ) in warned[0]


def test_graph_agents_apart_from_the_log(tmp_path: Path) -> None:
    """The real apartment graph's agent layer (poses at 3-28 s after 1970-01-01) in a 2026 log
    without TF: observed by that layer, which covers none of the log's time."""
    log = _write_log(tmp_path / "g.mcap", T0, real("dsg", "apartment_dsg.json"), 1200)
    result = run("build", log, "-o", tmp_path / "g.aion", "-q", "--format", "json")
    assert result.exit_code == 0, result.stderr
    warned = [line for line in result.stderr.splitlines() if "agent layer holds" in line]
    assert len(warned) == 1, result.stderr
    assert (
        "robot poses from 1970-01-01 00:00:03+00:00 to 1970-01-01 00:00:28+00:00, none in the "
        "logs' time (2026-01-05 10:00:00+00:00 .. 2026-01-05 10:19:50+00:00)"
    ) in warned[0]
    assert "--graph FILE" in warned[0]


def test_graph_agents_inside_the_log_time(tmp_path: Path) -> None:
    """The same graph in a log whose clock starts at 0 (1970-01-01 00:00): its agent poses
    at 3-28 s lie in the log's time, so no warning."""
    log = _write_log(tmp_path / "g.mcap", 0, real("dsg", "apartment_dsg.json"), 1200)
    result = run("build", log, "-o", tmp_path / "g.aion", "-q", "--format", "json")
    assert result.exit_code == 0, result.stderr
    assert "agent layer holds" not in result.stderr
    assert '"observation": "scene-graph agent layer"' in result.stdout


def test_api_build_warns_of_a_span_apart(tmp_path: Path) -> None:
    """``aion_cli.build(observed=...)`` checks the spans as ``--observed`` does, in its words."""
    import aion_cli as aion
    from aion_cli.errors import AionWarning

    log = _write_log(tmp_path / "a.mcap", T0)
    with pytest.warns(AionWarning) as caught:
        aion.build([log], output=tmp_path / "a.aion",
                   observed=[("2016-01-05 10:00", "2016-01-05 12:00")])  # fmt: skip
    apart = [str(w.message) for w in caught if "lies wholly before" in str(w.message)]
    assert len(apart) == 1
    assert apart[0].startswith('observed= "2016-01-05 10:00..2016-01-05 12:00"')


@pytest.mark.parametrize("workers", ["1", "2"])
def test_spans_a_robot_trajectory_sets_aside_are_not_said_to_count(
    office: Office, tmp_path: Path, workers: str
) -> None:
    """The office log has TF: a robot trajectory observes, and ``--observed`` is ignored with
    a warning saying so. A span apart from the log (January against its November) was also
    said to "still count as observed and empty", which it does not; only the warning that
    it is ignored remains, with one worker or two."""
    result = run("build", office.log, "-o", tmp_path / "r.aion", "--workers", workers,
                 "--observed", "2026-01-12 08:00..2026-01-12 09:00", "-q")
    assert result.exit_code == 0, result.stderr
    assert "--observed ignored: the logs have a robot trajectory" in result.stderr
    assert "lies wholly before" not in result.stderr
    assert "count as observed" not in result.stderr
