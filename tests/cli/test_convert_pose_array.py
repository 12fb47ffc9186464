"""``aion convert --message-type geometry_msgs/msg/PoseArray``: a detection without a heading
(a THÖR row with speed 0 and angle 0, a track's lone sample) must reach the build as one
without a heading, not as a person walking along +x (yaw 0): PoseArray has no flag for an
unknown orientation, so it is written as the all-zero quaternion the build never reads."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import run, run_json


def test_unknown_headings_are_not_written_as_yaw_zero(tmp_path: Path) -> None:
    rows = ["0.0,1,0.0,0.0,1.0,1.5708", "1.0,1,0.0,1.0,1.0,1.2", "2.0,1,0.3,2.0,1.0,1.0"]
    rows += [f"{t}.0,2,5.0,5.0,0.0,0.0" for t in range(3)]  # standing: speed 0, angle 0
    src = tmp_path / "thor.csv"
    src.write_text("\n".join(rows) + "\n")
    log = tmp_path / "p.bag"
    result = run(
        "convert", src, "--layout", "thor", "--start", "2026-01-05 10:00", "-o", log,
        "--message-type", "geometry_msgs/msg/PoseArray", "-q",
    )
    assert result.exit_code == 0, result.stderr
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--format", "json", "-q")
    # before: pose_yaw 6 (the standing person's three rows read as walking east). The first
    # message's yaw counts only once a later one differs (the build's orientation rule), so
    # the walker's last two rows have one; the standing person's rows have none
    assert report["headings"]["pose_yaw"] == 2
    assert report["headings"]["none"] == 4


def test_negative_track_ids_name_the_option_that_writes_rows_without_ids(tmp_path: Path) -> None:
    """(Before: "some rows have none (-1)" for ids of -5, and a hint naming a message type,
    not the option: ``write the rows as geometry_msgs/msg/PoseArray instead``.)"""
    from tests.cli.conftest import assert_one_line_error

    src = tmp_path / "atc.csv"
    src.write_text("1351038020,-5,1,2,0.3,0.1\n1351038021,-5,1.5,2,0.3,0.1\n")
    result = run("convert", src, "--layout", "atc", "-o", tmp_path / "a.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "atc.csv: line 1, column 2 (person_id): '-5'")
    assert "hint: write the rows without ids: --message-type geometry_msgs/msg/PoseArray" \
        in result.stderr
    ok = run("convert", src, "--layout", "atc", "-o", tmp_path / "b.mcap",
             "--message-type", "geometry_msgs/msg/PoseArray")
    assert ok.exit_code == 0, ok.stderr


def test_drop_ids_leaves_the_directions_to_the_builds_linker(tmp_path: Path) -> None:
    """``--drop-ids`` writes an ATC file as a leg detector publishes: PoseArray without ids
    or orientations. The file's angle column here says north (83° and 97° in turn, a yaw the
    build believes) while the positions walk east (+x, heading 0): the map must follow the
    positions, which only the build's linker can give (before: no option wrote such a log;
    --message-type PoseArray writes the column's angle as each pose's yaw, the build uses it)."""
    rows = [f"{1351038020 + t},7,{float(t)},0.0,1.0,{(1.45, 1.69)[t % 2]}" for t in range(12)]
    src = tmp_path / "atc.csv"
    src.write_text("\n".join(rows) + "\n")
    maps = {}
    for name, extra in (("yaw", ("--message-type", "geometry_msgs/msg/PoseArray")),
                        ("ids", ("--drop-ids",))):
        log = tmp_path / f"{name}.mcap"
        result = run("convert", src, "--layout", "atc", "-o", log, *extra, "-q")
        assert result.exit_code == 0, result.stderr
        maps[name] = tmp_path / f"{name}.aion"
        report = run_json("build", log, "-o", maps[name], "--format", "json", "-q")
        assert report["detections"]["used"] == 12
        if name == "ids":
            assert report["headings"]["pose_yaw"] == 0
            assert report["headings"]["linked"] >= 10
    for name, (low, high) in (("yaw", (80.0, 100.0)), ("ids", (-0.5, 0.5))):
        entries = run_json("predict", maps[name], "--historical", "--format", "json", "-q")
        directions = [e["direction_deg"] for e in entries["entries"]]
        assert len(directions) == 12  # a cell per metre walked
        known = [d for d in directions if d is not None]
        # the first message's yaw is set aside (orientations alike so far); the linked
        # track's first row takes its first step's direction
        assert len(known) == {"yaw": 11, "ids": 12}[name], (name, directions)
        assert all(low < d < high for d in known), (name, directions)


def test_drop_ids_refuses_a_message_type_with_ids(tmp_path: Path) -> None:
    from tests.cli.conftest import assert_one_line_error

    src = tmp_path / "atc.csv"
    src.write_text("1351038020,1,1,2,0.3,0.1\n1351038021,1,1.5,2,0.3,0.1\n")
    result = run("convert", src, "--layout", "atc", "-o", tmp_path / "a.mcap", "--drop-ids",
                 "--message-type", "spencer_tracking_msgs/msg/TrackedPersons")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "--drop-ids writes geometry_msgs/msg/PoseArray")
    assert not (tmp_path / "a.mcap").exists()
