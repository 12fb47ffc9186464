"""Header stamps on another clock than the log times: a simulation's stamps from 0 in a log
recorded on the wall clock, or the other way round. A detection's time is its stamp and what
was observed comes from the log times, so such a log built into nothing (every detection
dropped as ``before_window``, the error saying no more) or into a map of two clocks, without
a word. Now the build names the stamps, and the way out its hint gives works."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from pathlib import Path

from aion_cli.stamp_warnings import OFF_STAMPS, SIM_TIME
from tests.cli.conftest import assert_one_line_error
from tests.robustness.conftest import (
    T0,
    S,
    assert_same_arrays,
    build_json,
    map_arrays,
    person,
    run,
    write_log,
)

N = 1300
SIM_START_S = 100  # a simulation's clock, from 0: 100 s after 1970-01-01 00:00 UTC

MAPPING = '''
[[topic]]
topic = "/tracks"
msgtype = "spencer_tracking_msgs/msg/TrackedPersons"
array = "tracks"
position = "pose.pose.position"
velocity = "twist.twist.linear"
orientation = "pose.pose.orientation"
id = "track_id"
stamp = ""
'''


def utc_text(t_ns: int) -> str:
    when = datetime(1970, 1, 1, tzinfo=UTC) + timedelta(microseconds=t_ns // 1000)
    return when.strftime("%Y-%m-%d %H:%M:%S UTC")


def test_sim_time_stamps_are_named_and_log_times_build_the_map(tmp_path: Path) -> None:
    stamped = [person(T0 + k * S, (2.1, 0.1, 0.0)) for k in range(N)]
    sim = [person(T0 + k * S, (2.1, 0.1, 0.0), header_ns=(SIM_START_S + k) * S) for k in range(N)]
    log = write_log(tmp_path / "sim.mcap", sim)
    result = run("build", log, "-o", tmp_path / "sim.aion")
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "none of the 1,300 people detections")
    hint = result.stderr.split("hint: ", 1)[1]
    assert f"{N:,} detection(s) on /tracks are stamped more than a day away" in hint
    assert f"the first stamped 1970-01-01 00:01:40 UTC, logged {utc_text(T0)}" in hint
    assert 'stamp = ""' in hint
    assert not (tmp_path / "sim.aion").exists()
    # the way out the hint names: the log times, which give the map of a log stamped right
    mapping = tmp_path / "tracks.toml"
    mapping.write_text(MAPPING)
    report = build_json(log, "-o", tmp_path / "log.aion", "--detections-mapping", mapping)
    assert report["detections"]["used"] == N
    build_json(write_log(tmp_path / "ok.mcap", stamped), "-o", tmp_path / "ok.aion")
    assert_same_arrays(map_arrays(tmp_path / "log.aion"), map_arrays(tmp_path / "ok.aion"))


def test_stamps_of_another_clock_than_the_log_times_are_a_warning(tmp_path: Path) -> None:
    """Log times from a simulation's 0, stamps on the wall clock: the map is built (it was,
    silently) and a warning says the two clocks differ; a log stamped at its log times has
    none."""
    late = [person((SIM_START_S + k) * S, (2.1, 0.1, 0.0), header_ns=T0 + k * S) for k in range(N)]
    report = build_json(write_log(tmp_path / "late.mcap", late), "-o", tmp_path / "late.aion")
    far = [w for w in report["warnings"] if "stamped more than a day away" in w]
    assert len(far) == 1
    assert far[0].startswith(f"{N:,} detection(s) on /tracks")
    assert f"the first stamped {utc_text(T0)}, logged 1970-01-01 00:01:40 UTC" in far[0]
    right = [person(T0 + k * S, (2.1, 0.1, 0.0)) for k in range(N)]
    report = build_json(write_log(tmp_path / "ok.mcap", right), "-o", tmp_path / "ok.aion")
    assert all("stamped more than a day away" not in w for w in report["warnings"])


def test_stamps_minutes_or_hours_off_the_log_times_are_a_warning(tmp_path: Path) -> None:
    """A tracker on another machine's clock (or zone) stamps its detections an hour after, or
    ten minutes before, their log times: the map put them into windows the log did not record
    (an hour late: 3 windows of detections beside the log's 3 empty ones; ten minutes early:
    600 dropped as before_window), without a word. Now a warning names the offset, and the
    way out it gives builds the map of the log stamped right."""
    n = 1800  # one detection a second for 30 minutes: three 600-s windows
    right = [person(T0 + k * S, (2.1, 0.1, 0.0)) for k in range(n)]
    reference = build_json(write_log(tmp_path / "ok.mcap", right), "-o", tmp_path / "ok.aion")
    assert reference["windows"] == 3
    assert all(OFF_STAMPS not in w for w in reference["warnings"])
    mapping = tmp_path / "tracks.toml"
    mapping.write_text(MAPPING)
    for name, offset_s, offset_text in (("late", 3600, "+1h00m00s"), ("early", -600, "-10m00s")):
        off = [
            person(T0 + k * S, (2.1, 0.1, 0.0), header_ns=T0 + (k + offset_s) * S) for k in range(n)
        ]
        log = write_log(tmp_path / f"{name}.mcap", off)
        report = build_json(log, "-o", tmp_path / f"{name}.aion")
        warned = [w for w in report["warnings"] if OFF_STAMPS in w]
        assert len(warned) == 1, report["warnings"]
        assert warned[0].startswith(f"{n:,} of the {n:,} detection(s) on /tracks")
        assert f"logged {utc_text(T0)}: {offset_text})" in warned[0]
        assert 'stamp = ""' in warned[0]
        fixed = build_json(
            log, "-o", tmp_path / f"{name}-log.aion", "--detections-mapping", mapping
        )
        assert fixed["windows"] == 3
        assert fixed["detections"]["used"] == n
        assert_same_arrays(
            map_arrays(tmp_path / f"{name}-log.aion"), map_arrays(tmp_path / "ok.aion")
        )


def test_a_trackers_latency_or_one_glitch_is_no_warning(tmp_path: Path) -> None:
    """Stamps seconds before their log times (a tracker's latency), or 6 of 1,200 (0.5 %) an
    hour off, are no clock of their own: no warning."""
    n = 1200
    latency = [person(T0 + k * S, (2.1, 0.1, 0.0), header_ns=T0 + (k - 5) * S) for k in range(n)]
    glitch = [
        person(T0 + k * S, (2.1, 0.1, 0.0), header_ns=T0 + (k + (3600 if k % 200 == 0 else 0)) * S)
        for k in range(n)
    ]
    for name, messages in (("latency", latency), ("glitch", glitch)):
        report = build_json(
            write_log(tmp_path / f"{name}.mcap", messages), "-o", tmp_path / f"{name}.aion"
        )
        assert all(OFF_STAMPS not in w for w in report["warnings"]), report["warnings"]


def test_a_trackers_clock_stepping_mid_log_is_a_warning(tmp_path: Path) -> None:
    """The tracker's clock steps an hour ahead halfway through (its log times stay right):
    the second half's 900 detections went into windows an hour later (5 windows observed,
    where the log recorded 3) without a word, as half is not most. Now it is a warning."""
    n = 1800
    step = [
        person(T0 + k * S, (2.1, 0.1, 0.0), header_ns=T0 + (k + (3600 if k >= n // 2 else 0)) * S)
        for k in range(n)
    ]
    report = build_json(write_log(tmp_path / "step.mcap", step), "-o", tmp_path / "step.aion")
    warned = [w for w in report["warnings"] if OFF_STAMPS in w]
    assert len(warned) == 1, report["warnings"]
    assert warned[0].startswith(f"900 of the {n:,} detection(s) on /tracks")
    assert f"logged {utc_text(T0 + 900 * S)}: +1h00m00s)" in warned[0]


def test_a_map_on_a_simulations_clock_from_1970_is_a_warning(tmp_path: Path) -> None:
    """Gazebo with use_sim_time: log times and stamps from 0. The map was built in 1970
    without a word (its hours and weekdays a Thursday's from midnight, ``predict --time now``
    56 years away). Now the build warns once, in one process or in two shards (two runs of
    the simulation three days apart); the same log on the wall clock does not."""
    logs = [
        write_log(
            tmp_path / f"sim{day}.mcap",
            [person((SIM_START_S + day * 3 * 86_400 + k) * S, (2.1, 0.1, 0.0)) for k in range(N)],
        )
        for day in range(2)
    ]
    for workers in ("1", "2"):
        report = build_json(*logs, "-o", tmp_path / f"sim-{workers}.aion", "--workers", workers)
        assert report["time_span"]["start_ns"] == SIM_START_S * S
        assert (workers == "2") == any("built 2 shards" in n for n in report["notes"])
        warned = [w for w in report["warnings"] if SIM_TIME in w]
        assert len(warned) == 1, report["warnings"]
        # 1970-01-01 was a Thursday
        assert warned[0].startswith("the map's data starts at 1970-01-01 00:01:40 UTC (a Thursday)")
        assert '--time "1970-01-01 08:00"' in warned[0]
    wall = [person(T0 + k * S, (2.1, 0.1, 0.0)) for k in range(N)]
    report = build_json(write_log(tmp_path / "wall.mcap", wall), "-o", tmp_path / "wall.aion")
    assert all(SIM_TIME not in w for w in report["warnings"])


def test_stamp_warnings_of_a_parallel_build_are_those_of_one_process(tmp_path: Path) -> None:
    """Two logs three days apart (two shards with --workers 2), stamped an hour off: each
    shard warned of its own half (two warnings, '1,300 of the 1,300'); now the parent warns
    once from the shards' counts added up, word for word what one process says (so does the
    warning of stamps a day away, from the same counts)."""
    day = 3 * 86_400

    def logs(name: str, logged: int, stamped: int) -> list[Path]:
        return [
            write_log(
                tmp_path / f"{name}{d}.mcap",
                [
                    person(
                        logged + (d * day + k) * S,
                        (2.1, 0.1, 0.0),
                        header_ns=stamped + (d * day + k) * S,
                    )
                    for k in range(N)
                ],
            )
            for d in range(2)
        ]

    for name, logged, stamped, kind in (("off", T0, T0 + 3600 * S, OFF_STAMPS),):
        said = []
        for workers in ("1", "2"):
            out = tmp_path / f"{name}-{workers}.aion"
            report = build_json(*logs(name, logged, stamped), "-o", out, "--workers", workers)
            assert (workers == "2") == any("built 2 shards" in n for n in report["notes"])
            said.append([w for w in report["warnings"] if kind in w])
            for path in tmp_path.glob(f"{name}?.mcap"):
                path.unlink()
        assert len(said[0]) == 1, said
        assert said[0][0].startswith(f"{2 * N:,} ")
        assert said[1] == said[0]


def test_aion_info_of_a_log_on_a_simulations_clock_warns_as_the_build_does(tmp_path: Path) -> None:
    """``aion info LOG`` showed a log of 1970 without a word; now it warns as the build will
    (the log's first message 100 s after 1970-01-01 00:00, a Thursday); a log on the wall
    clock gets no such warning."""
    import json

    sim_times = [(SIM_START_S + k) * S for k in range(10)]
    sim = write_log(tmp_path / "sim.mcap", [person(t, (2.1, 0.1, 0.0)) for t in sim_times])
    wall = write_log(tmp_path / "wall.mcap", [person(T0 + t, (2.1, 0.1, 0.0)) for t in sim_times])
    result = run("info", sim, "--format", "json")
    assert result.exit_code == 0, result.stderr
    (warning,) = [w for w in json.loads(result.stdout)["warnings"] if SIM_TIME in w]
    assert warning.startswith("the log's time starts at 1970-01-01 00:01:40 UTC (a Thursday)")
    result = run("info", wall, "--format", "json")
    assert all(SIM_TIME not in w for w in json.loads(result.stdout)["warnings"])
