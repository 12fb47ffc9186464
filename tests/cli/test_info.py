"""``aion info``: topics, counts and roles of the office log."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.conftest import (
    Office,
    assert_one_line_error,
    build_office_days,
    run,
    run_json,
    run_process,
)


def test_json_lists_topics_roles_and_counts(office: Office) -> None:
    doc = run_json("info", office.log, "--format", "json")
    expected = office.expected
    topics = {t["topic"]: t for t in doc["topics"]}
    assert topics["/tracks"]["count"] == expected.track_messages
    assert topics["/tracks"]["role"] == "detections"
    assert topics["/tracks"]["type"] == "spencer_tracking_msgs/msg/TrackedPersons"
    assert topics["/hydra/backend/dsg"]["role"] == "scene_graph"
    assert topics["/hydra/backend/dsg"]["count"] == expected.graph_messages
    assert topics["/tf"]["role"] == "tf"
    assert topics["/tf"]["count"] == expected.tf_messages
    total = expected.track_messages + expected.graph_messages + expected.tf_messages
    assert doc["messages"] == total
    assert doc["start_ns"] == expected.start_ns
    assert doc["end_ns"] == expected.end_ns
    assert doc["duration_s"] == (expected.end_ns - expected.start_ns) / 1e9
    assert doc["will_use"] == {
        "detections": ["/tracks"],
        "scene_graph": ["/hydra/backend/dsg"],
        "tf": ["/tf"],
    }
    assert doc["cannot_read"] == []
    from aion_cli.formats.dsg import installed_version

    assert doc["dsg_versions"] == {"/hydra/backend/dsg": [installed_version()]}
    assert doc["files"][0]["size_bytes"] == office.log.stat().st_size
    assert "fixed_sensor" not in doc  # TF and a scene graph: not a fixed sensor


def test_a_fixed_sensor_log_says_how_much_of_its_span_holds_messages(tmp_path: Path) -> None:
    """The office session (08:00-08:20, no TF, no graph) on three days in a row: 2 windows a
    day hold messages, 6 of the 290 windows from the first to the last; the table names
    --observed for a tracker that is silent when nobody is there. One session alone fills
    its span: no such advice."""
    from tests.cli.logdata import write_office_log

    log = tmp_path / "mornings.mcap"
    write_office_log(log, graph=False, tf=False, later_sessions_s=(86_400, 2 * 86_400))
    doc = run_json("info", log, "--format", "json")
    assert doc["fixed_sensor"] == {"windows_with_messages": 6, "span_windows": 290,
                                   "recorded_windows": 6.0, "recorded_s": 3600.0,
                                   "window_s": 600.0,
                                   # Monday to Wednesday, 08:00-08:20 UTC
                                   "hours_with_messages": "weekdays 08:00-09:00; weekends "
                                                          "none (UTC)",
                                   # its first detection messages all hold people
                                   "empty_in_first_messages": 0}
    table = run("info", log)
    assert "fixed sensor over the 6 windows of 10 min with messages, 2% of its span; the " \
        "others are unknown, not empty" in " ".join(table.stderr.split())
    assert "note: hours with messages: weekdays 08:00-09:00; weekends none" in " ".join(
        table.stderr.split()
    )  # in UTC, which the header names once
    assert "--observed START..END" in table.stderr
    one = tmp_path / "one.mcap"
    write_office_log(one, graph=False, tf=False)
    assert run_json("info", one, "--format", "json")["fixed_sensor"]["span_windows"] == 2
    assert "--observed" not in run("info", one).stderr


def test_a_log_shorter_than_a_window_is_not_called_a_whole_window(tmp_path: Path) -> None:
    """A 255-second fixed-sensor log holds messages in one 10-minute window and recorded
    about 255/600 of it, which the build counts (a window a log starts or ends inside counts
    for the part recorded). info said "over the 1 window of 10 min with messages, 100% of its
    span", as if ten minutes had been watched; it now gives the share recorded, the build's."""
    from aion_cli.mapquery import load_map
    from tests.cli.logdata import write_office_log

    log = tmp_path / "short.mcap"
    write_office_log(log, graph=False, tf=False, duration_s=255)
    doc = run_json("info", log, "--format", "json")
    fixed = doc["fixed_sensor"]
    assert (fixed["windows_with_messages"], fixed["span_windows"]) == (1, 1)
    # first to last message, the last placed to the end of its 10-second step
    assert abs(fixed["recorded_windows"] - doc["span_s"] / 600) <= 10 / 600 + 0.005
    run_json("build", log, "-o", tmp_path / "short.aion", "--format", "json")
    state = load_map(tmp_path / "short.aion").state
    built = state.windows_observed(state.entries.live_rows(), True).max()
    assert fixed["recorded_windows"] == round(float(built), 2)
    assert fixed["recorded_s"] == round(float(built) * 600, 1)
    note = " ".join(run("info", log).stderr.split())
    assert f"over the 1 window of 10 min with messages, {fixed['recorded_windows']:g} of it " \
        f"counted as recorded ({round(fixed['recorded_s'] / 60, 1):g} min" in note
    assert "100%" not in note


@pytest.mark.parametrize("name", ["positive_1_extracted.bag", "positive_2_extracted.bag"])
def test_a_bag_under_a_second_says_the_time_it_holds(name: str) -> None:
    """leg_tracker's bags hold 0.48 s and 0.27 s of messages (rosbags reads their first and
    last message): info's header said "duration: 0.5 s" / "0.3 s" and its fixed-sensor note
    "0.02 of it recorded (10 s: ...)", the 10-second step the build places a log's ends to.
    The note now says the build counts 10 s and the log holds what it holds; the JSON keeps
    the build's count (the map is unchanged)."""
    from rosbags.rosbag1 import Reader

    from aion_cli.number_text import significant
    from tests.shared_data import real

    bag = real("logs", "leg_tracker", name)
    with Reader(bag) as reader:
        times = [t for _, t, _ in reader.messages()]
    held = (max(times) - min(times)) / 1e9
    assert held < 1.0
    doc = run_json("info", bag, "--format", "json")
    assert doc["recorded_s"] == pytest.approx(held, abs=1e-6)
    fixed = doc["fixed_sensor"]
    assert (fixed["recorded_windows"], fixed["recorded_s"]) == (0.02, 10.0)  # the build's
    shown = " ".join(run("info", bag).stdout.split() + run("info", bag).stderr.split())
    said = f"{significant(held, 2)} s"  # two significant digits: 0.48 s, 0.27 s
    assert f"duration: {said} (" in shown
    assert f"0.02 of it counted as recorded (10 s; the log holds {said}: build places a " \
        "log's first and last message to steps of 10 s" in shown
    assert "of it recorded (10 s" not in shown


def test_a_scene_graph_without_robot_poses_and_no_tf_is_a_fixed_sensor(tmp_path: Path) -> None:
    """A log with detections and a scene graph but no TF: the build takes it as a fixed sensor
    unless the first graph's agent layer holds robot poses (test_build's
    test_observation_from_the_scene_graph_agents_or_fixed). info gave the fixed-sensor note
    and JSON ``fixed_sensor`` only to logs without a scene graph; now it follows the build."""
    from tests.cli.logdata import write_office_log

    fixed = tmp_path / "fixed.mcap"
    write_office_log(fixed, tf=False, duration_s=1800)
    doc = run_json("info", fixed, "--format", "json")
    assert doc["will_use"]["scene_graph"] == ["/hydra/backend/dsg"]
    assert doc["fixed_sensor"]["windows_with_messages"] == 3
    note = " ".join(run("info", fixed).stderr.split())
    assert "no robot trajectory (no TF, and the scene graph's agent layer holds no robot " \
        "poses): `aion build` takes the log as a fixed sensor over the 3 windows" in note
    agents = tmp_path / "agents.mcap"
    write_office_log(agents, tf=False, agents=True, duration_s=1800)
    assert "fixed_sensor" not in run_json("info", agents, "--format", "json")
    assert "fixed sensor" not in run("info", agents).stderr
    bare = tmp_path / "bare.mcap"  # neither TF nor a scene graph: as before
    write_office_log(bare, graph=False, tf=False, duration_s=1800)
    assert "no robot trajectory (no TF, no scene graph)" in " ".join(
        run("info", bare).stderr.split()
    )


def test_unsupported_topics_are_listed(tmp_path: Path) -> None:
    from aion_cli.formats.writers import LogWriter

    log = tmp_path / "odd.mcap"
    with LogWriter(log, "mcap") as writer:
        writer.write("/chatter", "std_msgs/msg/String", {"data": "hi"}, 1_000_000_000)
    doc = run_json("info", log, "--format", "json")
    assert doc["cannot_read"] == ["/chatter (std_msgs/msg/String)"]
    assert doc["will_use"]["detections"] == []
    table = run("info", log)
    assert table.exit_code == 0
    assert "/chatter" in table.stdout
    assert "no people-detection topic" in table.stderr


def test_table_for_people(office: Office) -> None:
    result = run("info", office.log)
    assert result.exit_code == 0, result.stderr
    assert "/tracks" in result.stdout
    assert "detections" in result.stdout
    assert "scene_graph" in result.stdout


def test_bad_logs(tmp_path: Path) -> None:
    result = run("info", tmp_path / "nope.bag")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "nope.bag")
    text = tmp_path / "notes.txt"
    text.write_text("hello")
    result = run("info", text)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr)
    result = run("info")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "LOGS")


def test_subprocess_info(office: Office) -> None:
    proc = run_process("info", office.log, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["will_use"]["detections"] == ["/tracks"]


def test_info_on_a_map(office: Office) -> None:
    doc = run_json("info", office.map, "--format", "json")
    assert doc["format"] == "aion-map"
    assert doc["counts"]["used"] == 300
    assert doc["inputs"][0]["name"] == "office.mcap"
    assert doc["time_span"] == {
        "start_ns": office.expected.start_ns,
        "end_ns": office.expected.end_ns,
    }
    assert "members" not in doc
    table = run("info", office.map)
    assert table.exit_code == 0
    assert "office.mcap" in table.stdout
    # the span's ends in the map's zone (UTC here), with their weekdays
    from datetime import UTC, datetime

    def when(t_ns: int) -> str:
        return datetime.fromtimestamp(t_ns / 1e9, UTC).strftime("%a %Y-%m-%d %H:%M")

    ends = f"{when(office.expected.start_ns)} to {when(office.expected.end_ns)} UTC"
    assert ends in " ".join(table.stdout.replace("│", " ").split()), table.stdout  # wrapped
    mixed = run("info", office.map, office.log)
    assert mixed.exit_code == 2
    assert_one_line_error(mixed.stderr, "not both")


def test_info_on_a_map_counts_the_families(office: Office, tmp_path: Path) -> None:
    """The manifest tallies the entries forecast by each family. One day: nothing is scored
    (the day is pending, and has no earlier day to be scored against even provisionally), so
    the five places the robot watched (p1, p3, p4 with people, p0 and p2 without) are all
    ``static``; p5 and p6, out of its range, have no entry. The table shows the same."""
    doc = run_json("info", office.map, "--format", "json")
    assert doc["families"] == {
        "flow": {"static": 5},
        "direction": {"static": 5},
        "reconciled": False,
        "scored_windows": 0.0,
        "scored_days": 0,
        "last_day_provisional": False,
        "observed_bins": [8],  # the office log's 20 minutes from Monday 08:00 UTC
        "rules": 3,  # the choice rules the counts were taken under (engine.temporal.choice)
        # no closed day: the pending Monday seen once as a query absorbs it (its open window
        # is no second day), nothing scored against an earlier day, the default calendar
        "calendar": {"calendar": "day_weekend", "gain": 0.0, "weekday_days": 1},
    }
    assert doc["timezone"] == "UTC"
    table = run("info", office.map)
    assert table.exit_code == 0, table.stderr
    lines = table.stdout.splitlines()
    assert any("flow models" in line and "static 5" in line for line in lines)
    assert any("direction models" in line and "static 5" in line for line in lines)
    assert any("days scored" in line and line.split("│")[2].strip() == "0" for line in lines)
    hours = "weekdays 08:00-09:00; weekends none"  # UTC: named once, by the time span row
    assert any("hours observed" in line and hours in line and "UTC" not in line
               for line in lines)
    assert any("time span" in line and line.rstrip(" │").endswith("UTC") for line in lines)
    assert any("calendar" in line and "too few days" in line for line in lines)
    assert "models note" not in table.stdout


def test_info_says_when_an_older_aion_counted_the_families(office: Office, tmp_path: Path) -> None:
    """Family counts taken under other choice rules (a map's manifest without ``rules``, as
    aion wrote before the rules changed) are not what this version's queries use: info says
    so, and where to see the families in use."""
    import json
    import zipfile

    old = tmp_path / "old.aion"
    with zipfile.ZipFile(office.map) as zin, zipfile.ZipFile(old, "w") as zout:
        for info in zin.infolist():
            data = zin.read(info)
            if info.filename == "manifest.json":
                manifest = json.loads(data)
                del manifest["families"]["rules"]
                data = json.dumps(manifest).encode()
            zout.writestr(info, data)
    table = run("info", old)
    assert table.exit_code == 0, table.stderr
    shown = " ".join(table.stdout.split())
    assert "models note" in shown
    assert "aion predict --format json names each entry's family" in " ".join(
        shown.replace("│", " ").split()
    )


def test_families_after_a_scored_day(tmp_path: Path) -> None:
    """Three daily copies of the office log: the middle day is scored against the first, in
    the 2 windows the robot watched each of the 5 places in its range (10 entry-windows);
    the last day stays pending and is scored provisionally in its one closed window (its
    second is still open: 5 entry-windows more). Every entry is counted once per kind."""
    out = build_office_days(tmp_path)
    families = run_json("info", out, "--format", "json")["families"]
    assert families["scored_windows"] == 10.0 + 5.0
    assert families["scored_days"] == 2  # the middle day, and the last provisionally
    assert families["last_day_provisional"] is True
    shown = run("info", out).stdout
    assert any("days scored" in line and "provisionally" in line for line in shown.splitlines())
    assert sum(families["flow"].values()) == 5
    assert sum(families["direction"].values()) == 5
    assert set(families["flow"]) <= {"static", "shape", "profile", "fremen1", "fremen2"} | {
        "fremen3",
        "fremen4",
    }
    assert isinstance(families["reconciled"], bool)


def test_a_map_lists_its_rooms_with_their_names(office: Office, tmp_path: Path) -> None:
    """The office graph (tests/cli/logdata.py) has rooms 0..2 named room0..room2, holding
    places 0-1, 2-4 and 5-6: info lists them, with names plan and predict accept."""
    report = run_json("info", office.map, "--format", "json")
    assert report["rooms"] == [
        {"id": "R0", "name": "room0", "places": 2},
        {"id": "R1", "name": "room1", "places": 3},
        {"id": "R2", "name": "room2", "places": 2},
    ]
    table = run("info", office.map)
    assert "room0 (R0), room1 (R1), room2 (R2)" in table.stdout
    from tests.cli.logdata import write_office_log

    bare = tmp_path / "bare.mcap"
    write_office_log(bare, graph=False)
    cells = tmp_path / "cells.aion"
    assert run("build", bare, "-o", cells).exit_code == 0
    assert run_json("info", cells, "--format", "json")["rooms"] == []


def test_days_scored_are_the_map_s_days_not_an_entry_s_sum(sample_map: Path) -> None:
    """The sample's five workdays: four scored (Tuesday..Friday, Friday provisionally). Cells
    bound to a node over the same days make that node count their days too (the sample has
    such nodes), which is not how many days the map scored."""
    from aion_cli.mapquery import load_map

    state = load_map(sample_map).state
    rows = state.entries.canonical_order()
    assert int(state.scored_temporal().flow_days[rows].max()) > 4  # what "days scored" said
    families = run_json("info", sample_map, "--format", "json")["families"]
    assert families["scored_days"] == 4


def test_options_that_do_not_apply_are_refused(office: Office, tmp_path: Path) -> None:
    """Options for logs given with a map or a scene-graph file did nothing, exit 0; --verify
    with a scene-graph file too, and --nav-layer (for scene-graph files) with a log. They are
    refused, naming what would apply."""
    from tests.cli.logdata import save_graph_file

    graph = save_graph_file(tmp_path / "plain.json")
    for args, fragment in (
        ([office.map, "--suggest-mapping", "/tf"], "--suggest-mapping does not apply to a map"),
        ([office.map, "--nav-layer", "99"], "--nav-layer does not apply to a map"),
        ([office.map, "--log-format", "mcap"], "--log-format does not apply to a map"),
        ([graph, "--verify"], "--verify does not apply to a scene-graph file"),
        ([office.log, "--nav-layer", "99"], "--nav-layer does not apply to logs"),
    ):
        result = run("info", *args)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, fragment)
    assert run("info", office.map, "--verify").exit_code == 0
    assert run("info", graph, "--nav-layer", "places").exit_code == 0
    assert run("info", office.log, "--tz", "UTC", "--verify").exit_code == 0


def test_a_map_of_before_exposure_shows_the_whole_windows_it_builds_with(
    office: Office, tmp_path: Path
) -> None:
    """A map written before ``exposure`` existed stores no such key; it reads, and a build
    continues it, with ``exposure = false``, so ``aion info`` says so rather than "defaults"
    (the default is true)."""
    import zipfile

    old = tmp_path / "old.aion"
    with zipfile.ZipFile(office.map) as zin, zipfile.ZipFile(old, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "manifest.json":
                manifest = json.loads(data)
                del manifest["config"]["exposure"]
                del manifest["state"]["config"]["exposure"]
                data = json.dumps(manifest).encode()
            zout.writestr(item, data)
    doc = run_json("info", old, "--format", "json")
    assert doc["config"]["exposure"] is False
    table = run("info", old)
    assert table.exit_code == 0, table.stderr
    assert "exposure=False" in table.stdout
    assert "exposure" not in run("info", office.map).stdout  # the default: not listed


def test_a_fixed_sensors_hours_in_the_zone_it_will_be_built_in(tmp_path: Path) -> None:
    """People at 07:00-07:20 Berlin time on the Friday before the spring change and the
    Monday after it: 06:00 and 05:00 UTC. info gave the hours in UTC only (05:00-07:00, two
    hours where the tracker kept one); --tz gives them as a build with that --tz learns them.
    The UTC instants are computed here with zoneinfo."""
    from datetime import datetime
    from zoneinfo import ZoneInfo

    berlin = ZoneInfo("Europe/Berlin")
    rows = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    for track, day in enumerate((27, 30)):
        start = int(datetime(2026, 3, day, 7, 0, tzinfo=berlin).timestamp())
        rows += [f"{(start + k) * 10**9},{track},{k * 0.01:.2f},0.0,0.0,0.0,1.0"
                 for k in range(0, 1200, 2)]
    csv = tmp_path / "mornings.csv"
    csv.write_text("\n".join(rows) + "\n")
    log = tmp_path / "mornings.mcap"
    converted = run("convert", csv, "-o", log, "-q")
    assert converted.exit_code == 0, converted.stderr
    utc = run_json("info", log, "--format", "json")["fixed_sensor"]["hours_with_messages"]
    assert utc == "weekdays 05:00-07:00; weekends none (UTC)"
    local = run_json("info", log, "--tz", "Europe/Berlin", "--format", "json")
    assert local["fixed_sensor"]["hours_with_messages"] == (
        "weekdays 07:00-08:00; weekends none (Europe/Berlin)"
    )
    refused = run("info", log, "--tz", "Mars/Olympus")
    assert refused.exit_code == 2
    assert "unknown time zone 'Mars/Olympus'" in refused.stderr


def test_the_table_shows_the_windows_observed_as_the_build_counted(office: Office) -> None:
    """The map's table showed no 'windows observed' (only its JSON's counts.windows), the row
    the build's own summary printed. The office log covers 08:00 to 08:20 on Monday, with the
    robot's poses throughout: two 10-minute windows."""
    assert office.build["windows"] == 2
    assert run_json("info", office.map, "--format", "json")["counts"]["windows"] == 2
    table = run("info", office.map)
    assert table.exit_code == 0, table.stderr
    row = next(line for line in table.stdout.splitlines() if "windows observed" in line)
    assert row.split("│")[2].strip() == "2"
