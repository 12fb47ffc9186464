"""``aion build --observed``: a fixed sensor's declared recording spans, for trackers that
publish only when they see someone. Checked against window counts known from the generated
logs and against the rhythm a silent night then shows."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.mapfile import read_manifest
from tests.cli.conftest import assert_one_line_error, run, run_json
from tests.cli.logdata import T0, write_office_log

DAY_S = 86_400
SESSIONS = 4
"""The office log's 20-minute session (08:00-08:20 UTC, people for the first minutes) on four
days in a row: a tracker that is silent when nobody is there records nothing in between."""


@pytest.fixture(scope="module")
def mornings(tmp_path_factory: pytest.TempPathFactory) -> Path:
    log = tmp_path_factory.mktemp("observed") / "mornings.mcap"
    later = tuple(d * DAY_S for d in range(1, SESSIONS))
    write_office_log(log, graph=False, tf=False, later_sessions_s=later)
    return log


def _total_flow(path: Path, when: str) -> float:
    entries = run_json("predict", path, "--time", when, "--format", "json")["entries"]
    return sum(float(e["flow"] or 0.0) for e in entries)


def test_declared_spans_make_silent_windows_observed_empty(
    mornings: Path, tmp_path: Path
) -> None:
    """Messages in two 10-minute windows a day (08:00-08:20): 8 windows observed. Declaring
    the days observed makes every window of the span observed, from its start (00:00 on the
    22nd, 32 h before the first message) to its end (00:00 on the 28th, 63 h 40 min after
    the last message): 6 days = 864 windows (the windows after the last message were left
    unknown, 626, where the same log converted with the span observed them)."""
    silent = run_json("build", mornings, "-o", tmp_path / "a.aion", "--format", "json")
    assert silent["observation"].startswith("fixed sensor over the 8 windows with messages")
    assert silent["windows"] == 8  # the summary counts the open last window as the flows do
    assert silent["hours_observed"] == "weekdays 08:00-09:00; weekends none (UTC)"
    # 8 of 434 windows: the build says the rest is unknown and how to declare it
    assert (
        "the fixed sensor observed 2% of its logs' time (the windows in which a log recorded "
        "a message, each log from its first message to its last; the rest is unknown, not "
        "empty): if its tracker is silent when nobody is there, declare the spans it was "
        "recording with aion build --observed"
    ) in silent["notes"]
    declared = run_json(
        "build", mornings, "-o", tmp_path / "b.aion", "--format", "json",
        "--observed", "2026-11-22 00:00..2026-11-28 00:00",
    )
    assert declared["observation"] == (
        "fixed sensor over the 864 windows with messages or --observed (864 of the 864 windows "
        "of 10 min from the first to the last)"
    )
    assert declared["windows"] == 864
    added = "--observed: 856 window(s) without a message"
    assert any(note.startswith(added) for note in declared["notes"])
    assert declared["detections"] == silent["detections"]
    assert not any(note.startswith("the fixed sensor observed") for note in declared["notes"])


def test_a_silent_night_is_forecast_as_a_night(mornings: Path, tmp_path: Path) -> None:
    """Without the declaration the nights were never observed, so nothing says they are
    empty: 03:00 is forecast nearly as busy as 08:00. Declared, the nights are observed empty and
    the morning rush stands out."""
    silent, declared = tmp_path / "a.aion", tmp_path / "b.aion"
    run_json("build", mornings, "-o", silent, "--format", "json")
    run_json(
        "build", mornings, "-o", declared, "--format", "json",
        "--observed", f"{T0 // 10**9 - 8 * 3600}..{T0 // 10**9 + SESSIONS * DAY_S}",
    )
    after = "2026-11-27"
    assert _total_flow(silent, f"{after} 03:00") > 0.5 * _total_flow(silent, f"{after} 08:05")
    night = _total_flow(declared, f"{after} 03:00")
    morning = _total_flow(declared, f"{after} 08:05")
    assert morning > 0
    assert night <= 0.05 * morning
    # and the forecast says which: the silent map observed 08:00-09:00 only
    assert read_manifest(silent)["families"]["observed_bins"] == [8]
    # Monday to Thursday, every hour: the weekday bins
    assert read_manifest(declared)["families"]["observed_bins"] == list(range(24))
    unknown = run("predict", silent, "--time", f"{after} 03:00", "--tz", "UTC")
    assert (
        "no log observed 03:00-04:00 (UTC) on any day (the map observed 08:00-09:00): the "
        "forecast at this hour is extrapolated from the hours observed, not measured"
    ) in " ".join(unknown.stderr.split())
    known = run("predict", declared, "--time", f"{after} 03:00", "--tz", "UTC")
    assert "no log observed" not in known.stderr
    # JSON says it per time
    at = ("--time", f"{after} 03:00", "--tz", "UTC", "--format", "json")
    assert run_json("predict", silent, *at)["hour_observed"] is False
    assert run_json("predict", declared, *at)["hour_observed"] is True
    day = ("--from", f"{after} 06:00", "--to", f"{after} 10:00", "--tz", "UTC", "--format",
           "json")
    assert run_json("predict", silent, *day)["hour_observed"] == [False, False, True, False,
                                                                   False]


def test_a_span_after_the_logs_is_observed_as_in_a_converted_log(
    mornings: Path, tmp_path: Path
) -> None:
    """A span declared wholly after the log (31 days in 2030) is observed whole, as one
    wholly before it is and as the log converted with the span observes it (its markers
    run there); the time between the log and the span is declared by no span and stays
    unknown. It had been left unknown ("4,464 declared window(s) lie after the last log's
    last message")."""
    report = run_json(
        "build", mornings, "-o", tmp_path / "m.aion", "--format", "json",
        "--observed", "2030-01-01..2030-02-01",
    )
    assert report["observation"].startswith(
        "fixed sensor over the 4,472 windows with messages or --observed (4,472 of the "
        "167,856 windows of 10 min from the first to the last)"
    )
    assert [n for n in report["notes"] if n.startswith("--observed: ")] == [
        "--observed: 4,464 window(s) without a message taken as observed (744.0 h)",
    ]  # one log: no time between logs (the note had said "the time between the logs included")


def test_a_log_with_declared_spans_is_not_cut_into_time_shards(
    mornings: Path, tmp_path: Path
) -> None:
    report = run_json(
        "build", mornings, "-o", tmp_path / "m.aion", "--format", "json", "--workers", "2",
        "--observed", "2026-11-22..2026-11-28",
    )
    assert "--observed: a log is not cut into time shards (its declared spans count from its " \
        "first message to its last): built in sequence" in report["notes"]
    assert report["observation"].startswith("fixed sensor over the 864 windows")


def test_a_robot_trajectory_overrides_declared_spans(tmp_path: Path) -> None:
    log = tmp_path / "office.mcap"
    write_office_log(log)  # TF map -> base_link: the robot's poses say what it saw
    report = run_json(
        "build", log, "-o", tmp_path / "m.aion", "--format", "json",
        "--observed", "2026-11-23 07:00..2026-11-23 10:00",
    )
    assert report["observation"] == "tf map->base_link"
    assert any(w.startswith("--observed ignored: the logs have a robot trajectory")
               for w in report["warnings"])


@pytest.mark.parametrize(
    ("span", "fragment"),
    [
        ("2026-11-23 09:00", "expected START..END"),
        ("2026-11-23 09:00..2026-11-23 08:00", "the end is not after the start (read as"),
        # Berlin skips 02:00..03:00 that day: both ends are 03:00 CEST (01:00 UTC, the zone
        # the span is shown in), and it is said why
        ("2026-03-29 02:00 Europe/Berlin..2026-03-29 03:00 Europe/Berlin",
         "01:00:00+00:00: a clock change skips or repeats an hour there"),
        ("yesterday-ish..2026-11-23", "--observed 'yesterday-ish..2026-11-23'"),
    ],
)
def test_bad_spans_are_one_line_errors(
    mornings: Path, tmp_path: Path, span: str, fragment: str
) -> None:
    out = tmp_path / "m.aion"
    result = run("build", mornings, "-o", out, "--observed", span)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, fragment)
    assert not out.exists()


def test_the_python_api_takes_the_same_spans(mornings: Path, tmp_path: Path) -> None:
    import aion_cli as aion
    from aion_cli.errors import InputError

    made = aion.build(mornings, tmp_path / "api.aion",
                      observed=[("2026-11-22 00:00", "2026-11-28 00:00")])
    assert made.report.to_dict()["observation"].startswith("fixed sensor over the 864 windows")
    with pytest.raises(InputError, match="the end is not after the start"):
        aion.build(mornings, tmp_path / "bad.aion", observed=[("2026-11-24", "2026-11-23")])


def test_declared_time_between_two_logs_is_observed(tmp_path: Path) -> None:
    """Two sessions of the office log twelve hours apart, in two files, and a span declared
    over the day: the twelve hours between the files count as observed (a tracker recorded
    in daily files, silent between them), and the span's eight hours before the first file
    and its hours after the second, 00:00 to 24:00 = 144 windows; building both at once
    equals building the first with its half day, 00:00 to 12:00, and continuing with the
    other and the day, which fills from where the map's span stopped (the 72 windows from
    12:00)."""
    morning, evening = tmp_path / "morning.mcap", tmp_path / "evening.mcap"
    write_office_log(morning, graph=False, tf=False)
    write_office_log(evening, graph=False, tf=False, shift_s=DAY_S // 2)
    span = "2026-11-23 00:00..2026-11-24 00:00"
    both = run_json("build", morning, evening, "-o", tmp_path / "both.aion", "--format", "json",
                    "--observed", span)
    assert both["observation"].startswith("fixed sensor over the 144 windows with messages "
                                          "or --observed (144 of the 144 windows of 10 min")
    step = tmp_path / "step.aion"
    run_json("build", morning, "-o", step, "--format", "json", "--observed",
             "2026-11-23 00:00..2026-11-23 12:00")
    continued = run_json("build", evening, "--map", step, "--format", "json", "--observed", span)
    assert continued["observation"].startswith("fixed sensor over the 72 windows")
    assert continued["windows"] == both["windows"]
    maps = (read_manifest(tmp_path / "both.aion"), read_manifest(step))
    assert maps[0]["observation"] == maps[1]["observation"] == both["observation"]
    at = "2026-11-24 14:00"  # in the hours between the sessions: observed empty
    a = run_json("predict", tmp_path / "both.aion", "--time", at, "--format", "json")
    b = run_json("predict", step, "--time", at, "--format", "json")
    assert [(e["id"], e["flow"]) for e in a["entries"]] == \
        [(e["id"], e["flow"]) for e in b["entries"]]


def test_the_time_between_two_logs_is_no_sign_of_a_silent_tracker(tmp_path: Path) -> None:
    """Two recordings twelve hours apart, each with messages in every window of its own
    time: the 24 windows of the map's span hold 4 with messages, but the logs' own time is
    those 4, so no note suggests a silent tracker (it did: "observed 3% of the map's span")."""
    morning, evening = tmp_path / "morning.mcap", tmp_path / "evening.mcap"
    write_office_log(morning, graph=False, tf=False)
    write_office_log(evening, graph=False, tf=False, shift_s=DAY_S // 2)
    both = run_json("build", morning, evening, "-o", tmp_path / "both.aion", "--format", "json")
    assert both["observation"].startswith("fixed sensor over the 4 windows with messages")
    assert "(4 of the 74 windows of 10 min" in both["observation"]
    assert not any(note.startswith("the fixed sensor observed") for note in both["notes"])
    # the manifest keeps the logs' own time (2 windows each), summed by continuation and merge
    assert read_manifest(tmp_path / "both.aion")["counts"]["recording_windows"] == 4
    first, second = tmp_path / "first.aion", tmp_path / "second.aion"
    run_json("build", morning, "-o", first, "--format", "json")
    run_json("build", evening, "-o", second, "--format", "json")
    assert read_manifest(first)["counts"]["recording_windows"] == 2
    run_json("build", evening, "--map", first, "--format", "json")
    assert read_manifest(first)["counts"]["recording_windows"] == 4
    single = tmp_path / "single.aion"
    run_json("build", morning, "-o", single, "--format", "json")
    merged = run_json("merge", single, second, "-o", tmp_path / "merged.aion", "--format",
                      "json")
    assert read_manifest(tmp_path / "merged.aion")["counts"]["recording_windows"] == 4
    # 08:00 and 20:00 on a Monday: the merge's summary lists both hours
    assert merged["hours_observed"] == "weekdays 08:00-09:00, 20:00-21:00; weekends none (UTC)"


def test_a_log_that_starts_in_the_window_the_map_ended_in_is_counted_once(
    tmp_path: Path,
) -> None:
    """08:00-08:15 then 08:16-08:20: the logs' own time is the windows 08:00 and 08:10. A
    continued map added each build's windows, 08:10 twice (3; as leg_tracker's positive_1
    continued with positive_2, one window, gave 2), so continuing no longer equalled building
    both at once and the silent-tracker note measured against too long a time."""
    first, second = tmp_path / "first.mcap", tmp_path / "second.mcap"
    write_office_log(first, graph=False, tf=False, duration_s=900)
    write_office_log(second, graph=False, tf=False, shift_s=960, duration_s=240)
    run_json("build", first, second, "-o", tmp_path / "both.aion", "--format", "json")
    step = tmp_path / "step.aion"
    run_json("build", first, "-o", step, "--format", "json")
    run_json("build", second, "--map", step, "--format", "json")
    both, continued = read_manifest(tmp_path / "both.aion"), read_manifest(step)
    assert both["counts"]["recording_windows"] == 2
    assert continued["counts"]["recording_windows"] == 2
    assert continued["counts"]["recording_reach"] == both["counts"]["recording_reach"]


def test_a_merge_of_maps_that_meet_in_one_window_counts_it_once(tmp_path: Path) -> None:
    """The two logs above built apart and merged (in either order): the window both reach
    (08:10, the first's last and the second's first) is counted once, as one build and the
    continued map count it; the merge added the maps' windows (3)."""
    first, second = tmp_path / "first.mcap", tmp_path / "second.mcap"
    write_office_log(first, graph=False, tf=False, duration_s=900)
    write_office_log(second, graph=False, tf=False, shift_s=960, duration_s=240)
    run_json("build", first, "-o", tmp_path / "a.aion", "--format", "json")
    run_json("build", second, "-o", tmp_path / "b.aion", "--format", "json")
    for name, maps in (("ab", ("a", "b")), ("ba", ("b", "a"))):
        out = tmp_path / f"{name}.aion"
        run_json("merge", *(tmp_path / f"{m}.aion" for m in maps), "-o", out, "--format", "json")
        counts = read_manifest(out)["counts"]
        assert counts["recording_windows"] == 2, name
    apart = [read_manifest(tmp_path / f"{m}.aion")["counts"] for m in ("a", "b")]
    assert [c["recording_windows"] for c in apart] == [2, 1]
    assert apart[0]["recording_reach"] == apart[1]["recording_first"]


def test_a_sensor_mounted_by_static_tf_is_a_fixed_sensor_and_the_note_says_why(
    tmp_path: Path,
) -> None:
    """A tracker whose base_link is placed in the map by /tf_static alone: the detections are
    transformed with it (every one used, at the mounted position), but no poses over time say
    when it observed, so it is a fixed sensor. The note said 'TF has no map->base_link chain',
    which the log has."""
    from aion_cli.formats.writers import LogWriter

    log = tmp_path / "mounted.mcap"
    s = 10**9
    t0 = 1_767_600_000 * s  # 2026-01-05 08:00 UTC
    mount = {"header": {"stamp": {"sec": t0 // s}, "frame_id": "map"},
             "child_frame_id": "base_link",
             "transform": {"translation": {"x": 5.0, "y": 1.0}, "rotation": {"w": 1.0}}}
    with LogWriter(log, "mcap") as writer:
        writer.write("/tf_static", "tf2_msgs/msg/TFMessage", {"transforms": [mount]}, t0)
        for k in range(20):
            t = t0 + k * s
            writer.write("/people_tracker/pose_array", "geometry_msgs/msg/PoseArray", {
                "header": {"stamp": {"sec": t // s}, "frame_id": "base_link"},
                "poses": [{"position": {"x": 1.0, "y": 0.0}, "orientation": {"w": 1.0}}],
            }, t)
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--format", "json")
    assert report["detections"]["used"] == 20
    assert report["observation"].startswith("fixed sensor over the")
    assert (
        "TF joins map->base_link by static transforms only (/tf_static): no poses over time "
        "say when the sensor observed, so it is taken as a fixed sensor (see below)"
    ) in report["notes"]
    assert not any(n.startswith("TF has no") for n in report["notes"])
    entries = run_json("predict", tmp_path / "m.aion", "--historical", "--format",
                       "json")["entries"]
    busy = [e for e in entries if e["flow"]]
    assert {(e["x"], e["y"]) for e in busy} == {(6.25, 1.25)}  # cell of (6, 1): 0.5 m cells


def test_a_dynamic_chain_without_poses_is_not_called_static(tmp_path: Path) -> None:
    """map->odom and odom->base_link on /tf, at times that never overlap (localisation
    published for the first seconds only), detections in the map frame: the chain gives no
    pose, so the log is a fixed sensor, but the note said TF joined the frames 'by static
    transforms only (/tf_static)' in a log without /tf_static."""
    from aion_cli.formats.writers import LogWriter

    log = tmp_path / "gap.mcap"
    s = 10**9
    t0 = 1_767_600_000 * s  # 2026-01-05 08:00 UTC

    def link(parent: str, child: str, t: int) -> dict[str, object]:
        return {"transforms": [{
            "header": {"stamp": {"sec": t // s}, "frame_id": parent}, "child_frame_id": child,
            "transform": {"translation": {"x": 1.0, "y": 1.0}, "rotation": {"w": 1.0}},
        }]}

    with LogWriter(log, "mcap") as writer:
        for k in range(5):
            t = t0 + k * s
            writer.write("/tf", "tf2_msgs/msg/TFMessage", link("map", "odom", t), t)
        for k in range(100, 120):
            t = t0 + k * s
            writer.write("/tf", "tf2_msgs/msg/TFMessage", link("odom", "base_link", t), t)
            writer.write("/people_tracker/pose_array", "geometry_msgs/msg/PoseArray", {
                "header": {"stamp": {"sec": t // s}, "frame_id": "map"},
                "poses": [{"position": {"x": 1.0, "y": 0.0}, "orientation": {"w": 1.0}}],
            }, t)
    report = run_json("build", log, "-o", tmp_path / "g.aion", "--format", "json")
    assert report["observation"].startswith("fixed sensor over the")
    assert not any("static transforms only" in n for n in report["notes"])
    assert (
        "TF joins map->base_link, but at no time does every transform of the chain have a "
        "pose (its /tf transforms do not overlap in time): no robot trajectory, so it is taken "
        "as a fixed sensor (see below)"
    ) in report["notes"]


def test_a_span_ending_inside_a_window_counts_the_share_it_declares(
    mornings: Path, tmp_path: Path
) -> None:
    """Sessions 08:00-08:20 on four days in one log, a span declared 08:00-12:02 on the
    first: 24 whole windows to 12:00 and 0.2 of 12:00-12:10, then two windows on each later
    day, 30.2 windows. The window 12:00-12:10 holds no message and lies inside the log's
    open file; it counted whole (31 windows), as a span to 12:10 does, while a log that
    stopped recording at 12:02 counts 0.2 of it."""
    from aion_cli.mapquery import load_map

    def observed(end: str) -> tuple[float, int]:
        path = tmp_path / f"{end.replace(':', '')}.aion"
        report = run_json("build", mornings, "-o", path, "--format", "json",
                          "--observed", f"2026-11-23 08:00..2026-11-23 {end}")
        state = load_map(path).state
        return float(state.windows_observed(state.entries.live_rows(), True).max()), \
            report["windows"]

    most, windows = observed("12:02")
    assert most == pytest.approx(24 + 0.2 + 2 * (SESSIONS - 1))
    assert windows == 30  # 30.2, rounded
    assert observed("12:10") == (pytest.approx(25 + 2 * (SESSIONS - 1)), 31)


def test_the_api_reads_naive_spans_in_the_zone_the_map_follows_as_the_cli(
    tmp_path: Path,
) -> None:
    """A map of 2026-11-23 08:00-08:20 UTC built in Asia/Tokyo (UTC+9), continued with the
    next day's log without ``tz`` and the span 17:00 on the 23rd to 17:30 on the 24th: read in
    Tokyo (08:00 to 08:30 UTC, as ``build --map --observed`` reads it) it covers the whole
    time from the map's first message to the span's end, 08:00 on the 23rd to 08:30 on the
    24th = 144 + 3 = 147 windows. ``aion.build`` read it in UTC (from 17:00 UTC)."""
    import aion_cli as aion

    day0, day1 = tmp_path / "day0.mcap", tmp_path / "day1.mcap"
    write_office_log(day0, graph=False, tf=False)
    write_office_log(day1, graph=False, tf=False, shift_s=DAY_S)
    span = ("2026-11-23 17:00", "2026-11-24 17:30")
    cli, api = tmp_path / "cli.aion", tmp_path / "api.aion"
    for path in (cli, api):
        run_json("build", day0, "-o", path, "--format", "json", "--tz", "Asia/Tokyo")
    run_json("build", day1, "--map", cli, "--format", "json", "--observed", "..".join(span))
    aion.build(day1, api, continue_from=api, observed=[span])
    whole = ("fixed sensor over the 147 windows with messages or --observed (147 of the 147 "
             "windows of 10 min from the first to the last)")
    assert read_manifest(cli)["observation"] == whole
    assert read_manifest(api)["observation"] == whole  # before (in UTC): 94 of the 146


def test_the_api_reads_naive_spans_in_the_zone_the_logs_declare(tmp_path: Path) -> None:
    """A log declaring Asia/Tokyo (``convert --tz``) with one minute at 08:00 UTC on the 23rd
    and on the 24th: the span 17:00 to 17:30 the next day, naive, is read in Tokyo as
    ``build --observed`` reads it and covers both days' 08:00 to 08:30 on the 24th: 147
    windows (in UTC it would start nine hours late)."""
    import aion_cli as aion

    rows = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    rows += [f"{T0 + day * DAY_S * 10**9 + k * 10**9},{day + 1},{0.1 * k:.1f},0,0,0,1"
             for day in (0, 1) for k in range(60)]
    (tmp_path / "t.csv").write_text("\n".join(rows) + "\n")
    log = tmp_path / "t.mcap"
    assert run("convert", tmp_path / "t.csv", "-o", log, "--tz", "Asia/Tokyo").exit_code == 0
    made = aion.build(log, tmp_path / "m.aion", observed=[("2026-11-23 17:00", "2026-11-24 17:30")])
    assert made.timezone == "Asia/Tokyo"
    assert made.manifest.observation.startswith("fixed sensor over the 147 windows")
