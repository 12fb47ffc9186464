"""``aion convert``: a canonical tracks CSV becomes a log that ``aion build`` learns from."""

from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from aion_cli.formats.detections.frame import FrameDetections
from aion_cli.formats.observed_marks import OBSERVED_INTERVAL_NS
from tests.cli.conftest import Office, assert_one_line_error, run, run_json, warning_lines
from tests.cli.logdata import T0, save_graph_file
from tests.shared_data import SHARED_DATA

S = 1_000_000_000


def write_tracks(path: Path) -> int:
    """Two people walking +x along y = 0 and y = 0.4 at 1 m/s, 1 Hz, for 60 s."""
    lines = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    for k in range(60):
        for track, y in ((1, 0.0), (2, 0.4)):
            lines.append(f"{T0 + k * S},{track},{0.1 + k * 0.1:.3f},{y},0.0,0.0,1.0")
    path.write_text("\n".join(lines) + "\n")
    return 120


def test_convert_then_build_and_predict(tmp_path: Path) -> None:
    csv = tmp_path / "tracks.csv"
    n = write_tracks(csv)
    log = tmp_path / "tracks.mcap"
    result = run("convert", csv, "-o", log)
    assert result.exit_code == 0, result.stderr
    assert f"{n} detections of 2 tracks" in result.stderr
    info = run_json("info", log, "--format", "json")
    assert info["will_use"]["detections"] == ["/people_tracker/tracked_persons"]
    report = run_json("build", log, "--derive-graph", "--format", "json")
    assert report["detections"]["used"] == n
    assert report["observation"].startswith("fixed sensor")  # (wording: the build's)
    assert report["nodes"] >= 1
    doc = run_json(
        "predict", tmp_path / "tracks.aion", "--historical", "--layer", "places", "--format", "json"
    )
    with_flow = [e for e in doc["entries"] if e["flow"]]
    assert len(with_flow) == report["nodes_with_flow"] >= 1
    for entry in with_flow:
        assert entry["direction_bin"] == 4, entry  # heading 0 rad: bin [0, 45) degrees
        # the headings' own direction, not the bin's centre (22.5 degrees)
        assert entry["direction_deg"] == pytest.approx(0.0, abs=1e-9)


def test_convert_with_graph_into_a_bag(tmp_path: Path) -> None:
    csv = tmp_path / "tracks.csv"
    write_tracks(csv)
    graph = save_graph_file(tmp_path / "dsg.json")
    bag = tmp_path / "tracks.bag"
    result = run("convert", csv, "-o", bag, "--graph", graph)
    assert result.exit_code == 0, result.stderr
    report = run_json("build", bag, "--format", "json")
    assert report["graph"]["source"] == "log"
    assert report["nodes"] == 7


def test_bad_inputs(tmp_path: Path) -> None:
    result = run("convert", tmp_path / "none.csv", "-o", tmp_path / "x.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "none.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n1,2,three,4,5,6,7\n")
    result = run("convert", bad, "-o", tmp_path / "x.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "bad.csv")
    good = tmp_path / "good.csv"
    write_tracks(good)
    existing = tmp_path / "exists.mcap"
    existing.write_bytes(b"")
    result = run("convert", good, "-o", existing)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "exists")
    result = run("convert", good, "-o", tmp_path / "x.txt")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "x.txt")


# ----------------------------------------------------------------------------- --observed

DATA = SHARED_DATA
LINCOLN = DATA / "lincoln"
WINDOW = 600 * S


def read_back(log: Path) -> tuple[list[int], FrameDetections, npt.NDArray[np.int64]]:
    """Log times of all messages, the decoded detections and the 600-s windows recorded."""
    from aion_cli.formats.detections import adapter_for
    from aion_cli.formats.logs import open_logs

    with open_logs([log]) as logs:
        msgs = list(logs.messages())
        adapter = adapter_for(msgs[0].msgtype)
        assert adapter is not None
        return [m.log_time_ns for m in msgs], adapter.decode(msgs), logs.recorded_windows(WINDOW)


def assert_covered(windows: npt.NDArray[np.int64], start: int, end: int) -> None:
    """Every 600-s window of [start, end) holds a message."""
    touched = np.arange(start // WINDOW, (end - 1) // WINDOW + 1)
    assert np.isin(touched, windows).all(), (start, end)


def test_observed_spans_become_empty_messages(tmp_path: Path) -> None:
    csv = tmp_path / "tracks.csv"
    n = write_tracks(csv)  # 60 s from T0 = 2026-11-23 08:00 UTC
    log = tmp_path / "obs.mcap"
    later = T0 // S + 5 * 3600  # 13:00 UTC as UNIX seconds
    result = run(
        "convert",
        csv,
        "-o",
        log,
        "--tz",
        "Europe/Berlin",  # 08:30 Berlin = 07:30 UTC
        "--observed",
        "2026-11-23 08:30..2026-11-23T10:00:00+01:00",
        "--observed",
        f"{later}..{later + 1800}",
    )
    assert result.exit_code == 0, result.stderr
    spans = [(T0 - 1800 * S, T0 + 3600 * S), (later * S, (later + 1800) * S)]
    marks = sum(-(-(b - a) // OBSERVED_INTERVAL_NS) + 1 for a, b in spans)
    assert "observed: 2 span(s), 2.00 h" in result.stderr
    assert f"{marks:,} empty detection messages" in result.stderr
    # the zone read the spans, and the log carries it for the build (no --tz needed there)
    assert "the log carries the zone Europe/Berlin" in " ".join(result.stderr.split())
    # the second span lies hours after the minute of detections: a likely typo, said once
    warned = [line for line in result.stderr.splitlines() if "apart" in line or "wholly" in line]
    assert len(warned) == 1
    # named as typed, then as read and beside the detections' times, in the zone of --tz
    assert f'--observed "{later}..{later + 1800}"' in warned[0]
    assert "(2026-11-23 14:00:00+01:00 .. 2026-11-23 14:30:00+01:00) lies wholly after" in warned[0]
    assert "the detections (2026-11-23 09:00:00+01:00 .. 2026-11-23 09:00:59+01:00)" in warned[0]
    times, frames, windows = read_back(log)
    assert times == sorted(times)
    assert len(times) == 60 + marks
    for a, b in spans:
        assert_covered(windows, a, b)
        inside = [t for t in times if a <= t < b]
        assert max(np.diff([a, *inside, b])) <= OBSERVED_INTERVAL_NS
    assert len(frames) == n  # the detections are intact, the empty messages add none
    order = np.lexsort((frames.track_id, frames.t_ns))
    assert frames.t_ns[order].tolist() == [T0 + k * S for k in range(60) for _ in range(2)]
    assert frames.track_id[order].tolist() == [1, 2] * 60
    np.testing.assert_allclose(frames.xyz[order][::2, 0], 0.1 + np.arange(60) * 0.1)


def test_without_observed_spans_the_summary_says_so(tmp_path: Path) -> None:
    csv = tmp_path / "tracks.csv"
    write_tracks(csv)
    log = tmp_path / "plain.mcap"
    result = run("convert", csv, "-o", log)
    assert result.exit_code == 0, result.stderr
    assert "no observed spans" in result.stderr
    assert "--observed" in result.stderr
    times, _, _ = read_back(log)
    assert len(times) == 60  # only the detection messages


@pytest.mark.skipif(not LINCOLN.is_dir(), reason="the Lincoln data (../shared/data) is not here")
def test_lincoln_excerpt_converts_with_its_declared_span(tmp_path: Path) -> None:
    lines = (LINCOLN / "2017-06-09.txt").read_text().splitlines()[:403]  # header + 400 rows
    excerpt = tmp_path / "2017-06-09.txt"
    excerpt.write_text("\n".join(lines) + "\n")
    log = tmp_path / "lincoln.mcap"
    extra = "2017-06-20 09:00..2017-06-20 10:00"
    result = run(
        "convert", excerpt, "--layout", "lincoln", "-o", log, "--observed", extra, "--tz", "UTC"
    )
    assert result.exit_code == 0, result.stderr
    assert "400 detections" in result.stderr
    assert "declares recording from 2017-06-08 00:00:00" in result.stderr
    _, frames, windows = read_back(log)
    declared = (1496880000 * S, 1497225600 * S)  # the header: 06-08 .. 06-12 UTC
    assert_covered(windows, *declared)
    assert_covered(windows, 1497949200 * S, 1497952800 * S)
    assert len(frames) == 400
    assert (frames.track_id >= 0).all()
    first = [float(v) for v in lines[3].split()]
    assert int(frames.t_ns.min()) == round(first[0]) * S
    # the 05-31 variant (comma-separated, detector heading) converts too, without spans
    rows = (LINCOLN / "2017-05-31_heading.csv").read_text().splitlines()[:200]
    csv = tmp_path / "h.csv"
    csv.write_text("\n".join(rows) + "\n")
    result = run("convert", csv, "--layout", "lincoln", "-o", tmp_path / "h.bag")
    assert result.exit_code == 0, result.stderr
    assert "no observed spans" in result.stderr


@pytest.mark.parametrize(
    ("observed", "fragment"),
    [
        ("1700000100..1700000000", "end is not after the start"),
        ("1700000000..1700000000", "end is not after the start"),
        ("yesterday", "expected START..END"),
        ("..1700000000", "expected START..END"),
        ("1..2..3", "expected START..END"),
        ("1700000000..bogus", "cannot read the time 'bogus'"),
        ("2026-13-45 10:00..2026-11-23 11:00", "'2026-13-45 10:00': month must be in 1..12"),
    ],
)
def test_bad_observed_values(tmp_path: Path, observed: str, fragment: str) -> None:
    csv = tmp_path / "tracks.csv"
    write_tracks(csv)
    out = tmp_path / "x.mcap"
    result = run("convert", csv, "-o", out, "--observed", observed)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "--observed", fragment)
    assert not out.exists()


def test_bad_zone_and_start_with_lincoln(tmp_path: Path) -> None:
    csv = tmp_path / "tracks.csv"
    write_tracks(csv)
    result = run("convert", csv, "-o", tmp_path / "x.mcap", "--observed", "1..2", "--tz", "Mars/X")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "unknown time zone")
    lincoln = tmp_path / "l.txt"
    lincoln.write_text("1496999627 1.0 2.0\n1496999628 1.5 2.0\n")
    result = run(
        "convert", lincoln, "--layout", "lincoln", "-o", tmp_path / "l.mcap", "--start", "0"
    )
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "--start")


THOR_ROWS = "0.02,12001,-0.046,-3.443,0.141,2.356\n0.42,12001,-0.1,-3.4,0.1,2.3\n"
ATC_ROWS = "1351038020.9,9190802,-22.3,1.8,0.3,-0.4\n1351038021.9,9190802,-22.0,1.9,0.3,-0.4\n"


def test_a_file_of_another_layout_is_refused_naming_the_layout_it_looks_like(
    tmp_path: Path,
) -> None:
    """Without --layout (canonical), a THÖR file is refused and the hint says --layout thor;
    the error shows line 1 as it is written."""
    tracks = tmp_path / "run.csv"
    tracks.write_text("1496880000 1497225600\n-8 12\n-3 17\n1496999627.5 1.0 2.0\n")
    result = run("convert", tracks, "-o", tmp_path / "x.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "'1496880000 1497225600'")
    assert "hint: it looks like the lincoln layout" in result.stderr
    assert "pass --layout lincoln" in result.stderr
    tracks.write_text(THOR_ROWS)
    result = run("convert", tracks, "-o", tmp_path / "x.mcap")
    assert result.exit_code == 2
    assert "pass --layout thor" in result.stderr
    assert not (tmp_path / "x.mcap").exists()


def test_a_layout_that_fits_the_columns_but_not_the_content_is_warned(tmp_path: Path) -> None:
    """THÖR times from 0 read as ATC (UNIX seconds): converted, with a warning naming thor;
    ATC's UNIX times read as thor get no 'written from 1970' note, since they are not."""
    thor, atc = tmp_path / "thor.csv", tmp_path / "atc.csv"
    thor.write_text(THOR_ROWS)
    atc.write_text(ATC_ROWS)
    as_atc = run("convert", thor, "--layout", "atc", "-o", tmp_path / "a.mcap")
    assert as_atc.exit_code == 0, as_atc.stderr
    assert "warning: thor.csv was read as the atc layout" in as_atc.stderr
    assert "--layout thor" in as_atc.stderr
    # the layout is doubted: its place is not asserted ("the dataset was recorded in Osaka"
    # had followed the warning that the file is THÖR's)
    assert "Osaka" not in as_atc.stderr
    assert "Asia/Tokyo" not in as_atc.stderr
    # --start with times of the other kind: a THÖR clock read as ATC's UNIX seconds, ATC's
    # UNIX seconds read as a THÖR clock (it put them in 2061), ATC's own (2068): refused
    # before anything is written, naming the layout and what to give
    for source, layout, fragment, hint in (
        (thor, "atc", "times count from 0, which --layout atc reads as absolute",
         "--layout thor --start T"),
        (atc, "thor", "but they are UNIX seconds already", "--layout atc and without --start"),
        (atc, "atc", "--start does not apply to the atc layout", "drop --start"),
    ):
        shifted = run(
            "convert", source, "--layout", layout, "--start", "2026-01-05 10:00", "--tz", "UTC",
            "-o", tmp_path / "b.bag",
        )
        assert shifted.exit_code == 2, shifted.stderr
        assert_one_line_error(shifted.stderr, fragment)
        assert hint in shifted.stderr
        assert not (tmp_path / "b.bag").exists()
    as_thor = run("convert", thor, "--layout", "thor", "-o", tmp_path / "c.mcap")
    assert warning_lines(as_thor.stderr) == []
    assert "written from 1970-01-01" in as_thor.stderr
    atc_as_thor = run("convert", atc, "--layout", "thor", "-o", tmp_path / "d.mcap")
    assert atc_as_thor.exit_code == 0, atc_as_thor.stderr
    assert "looks like the atc layout" in atc_as_thor.stderr
    assert "Örebro" not in atc_as_thor.stderr
    assert "Stockholm" not in atc_as_thor.stderr
    # where the layout fits, its place is said
    assert "the dataset was recorded in Örebro" in as_thor.stderr
    # a date in 1970, not the digits of pytest's numbered temporary folder (pytest-1970/)
    assert "from 1970-" not in atc_as_thor.stderr


def test_a_log_or_a_map_given_as_tracks_is_named(office: Office, tmp_path: Path) -> None:
    """A log or a map where a tracks CSV belongs is refused in one line that says what it is
    and what to do with it, before any output exists."""
    for source, fragments, hint in (
        (office.log, ("office.mcap is a log", "not a tracks file"),
         f"aion build {shlex.quote(str(office.log))}"),  # the path given: a command to run
        (office.map, ("is an aion map", "not a tracks file"), "aion predict"),
    ):
        result = run("convert", source, "--layout", "atc", "-o", tmp_path / "x.mcap")
        assert result.exit_code == 2
        assert_one_line_error(result.stderr, *fragments)
        assert hint in " ".join(result.stderr.split())
        assert not (tmp_path / "x.mcap").exists()


@pytest.mark.parametrize("suffix", [".mcap", ".bag", "_ros2"])
def test_convert_tz_is_carried_by_the_log_into_the_build(tmp_path: Path, suffix: str) -> None:
    """convert --tz writes the zone into every container; build without --tz follows it, as
    it follows a simulated log's (before, only a note told the user to repeat --tz)."""
    from aion_cli.formats.log_zone import declared_zones

    csv = tmp_path / "tracks.csv"
    write_tracks(csv)
    log = tmp_path / f"tokyo{suffix}"
    convert = run("convert", csv, "-o", log, "--tz", "Asia/Tokyo")
    assert convert.exit_code == 0, convert.stderr
    assert declared_zones([log]) == {str(log): "Asia/Tokyo"}
    built = run("build", log, "-o", tmp_path / "m.aion")
    assert built.exit_code == 0, built.stderr
    info = run_json("info", tmp_path / "m.aion", "--format", "json")
    assert info["timezone"] == "Asia/Tokyo"


def test_convert_without_tz_declares_no_zone(tmp_path: Path) -> None:
    from aion_cli.formats.log_zone import declared_zones

    csv = tmp_path / "tracks.csv"
    write_tracks(csv)
    log = tmp_path / "utc.mcap"
    assert run("convert", csv, "-o", log).exit_code == 0
    assert declared_zones([log]) == {}


@pytest.mark.parametrize(
    ("layout", "rows", "where"),
    [
        ("eth", "0 1 0.0 0.0\n10 1 0.4 0.0\n10 -2 1 1\n", "line 3, column 2 (ped_id): '-2'"),
        ("atc", "1351038020,1,0,0,1,0\n1351038021,-5,1,0,1,0\n",
         "line 2, column 2 (person_id): '-5'"),
        ("canonical", "t_ns,track_id,x,y,z,heading_rad,speed_mps\n1000,3,0,0,0,nan,nan\n"
         "2000,4,0,0,0,nan,nan\n3000,-1,0,0,0,nan,nan\n", "line 4, column 2 (track_id): '-1'"),
    ],
)
def test_a_negative_track_id_names_the_file_and_its_line(
    tmp_path: Path, layout: str, rows: str, where: str
) -> None:
    """TrackedPersons needs ids of 0 or more: the refusal of a file with a negative one names
    the file and the line that holds it (it named neither: "TrackedPersons needs track ids of
    0 or more, a row has -2"), nothing is written, and the hint's PoseArray takes the file."""
    src = tmp_path / "tracks.txt"
    src.write_text(rows)
    out = tmp_path / "t.mcap"
    result = run("convert", src, "--layout", layout, "-o", out)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, f"{src}: {where}: TrackedPersons needs track ids")
    assert not out.exists()
    pose_array = ("--message-type", "geometry_msgs/msg/PoseArray")
    assert run("convert", src, "--layout", layout, *pose_array, "-o", out).exit_code == 0


def test_a_row_with_a_damaged_time_is_warned_of_as_the_build_drops_it(tmp_path: Path) -> None:
    """An ATC row whose time lost its last digits (``1351`` of ``1351038031``) made a log
    spanning 1970 to 2012 without a word from convert ("over 1,351,036,709 s"); the build then
    dropped its message as more than a day away from the others. Convert now warns of it
    with the same rule, naming its time; the build drops that one message (31 used of 32)."""
    rows = [f"{1351038020 + k},{k // 8},{0.5 * k},1.0,1.2,0.1" for k in range(32)]
    rows[11] = "1351," + rows[11].split(",", 1)[1]
    src = tmp_path / "atc.csv"
    src.write_text("\n".join(rows) + "\n")
    log = tmp_path / "atc.mcap"
    result = run("convert", src, "--layout", "atc", "-o", log)
    assert result.exit_code == 0, result.stderr
    assert "warning: atc.csv: 1 message of the log lies more than a day away from the others " \
        "(first: 1970-01-01 00:22:31+00:00)" in result.stderr
    built = run_json("build", log, "-o", tmp_path / "a.aion", "--format", "json", "-q")
    assert built["detections"]["used"] == 31, built
    assert [w for w in built["warnings"] if "more than a day away" in w], built["warnings"]
    src.write_text("\n".join(r for k, r in enumerate(rows) if k != 11) + "\n")
    clean = run("convert", src, "--layout", "atc", "-o", tmp_path / "c.mcap")
    assert "more than a day away" not in clean.stderr
