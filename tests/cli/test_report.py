"""``aion report``: the page references only the files the run wrote, agrees with ``aion info``
and ``aion predict``, escapes the map's strings, and fails cleanly on bad input.

The map is built once from the bundled sample log copied under a name full of HTML special
characters (``<``, ``&``, ``"``), so every test also sees how the page treats the map's own
strings."""

from __future__ import annotations

import html
import os
import shutil
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import SAMPLE, Office, assert_one_line_error, figure_texts, run, run_json

LOG_NAME = 'off<i>&amp;"ce.mcap'
WHEN = "2026-01-12 08:40"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
FIXED_BLUE = np.array([0x2C, 0x6F, 0xBB]) / 255.0


class _Page(HTMLParser):
    """Every reference (``src``/``href`` of any tag) and the cell texts of each table by id."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.refs: list[str] = []
        self.tags: set[str] = set()
        self.tables: dict[str, list[list[str]]] = {}
        self._table: str | None = None
        self._cell: list[str] | None = None
        self._in_body = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.add(tag)
        values = dict(attrs)
        self.refs += [v for k, v in attrs if k in ("src", "href", "srcset", "data") and v]
        if tag == "table":
            self._table = values.get("id") or "?"
            self.tables[self._table] = []
        elif tag == "tbody":
            self._in_body = True
        elif tag == "tr" and self._table is not None and self._in_body:
            self.tables[self._table].append([])
        elif tag == "td" and self._table is not None and self._in_body:
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if tag == "td" and self._cell is not None and self._table is not None:
            self.tables[self._table][-1].append("".join(self._cell))
            self._cell = None
        elif tag == "tbody":
            self._in_body = False
        elif tag == "table":
            self._table = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def _parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    page.close()
    return page


@pytest.fixture(scope="module")
def named_log_map(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sample built from a copy of its log under a name the page must escape."""
    folder = tmp_path_factory.mktemp("report")
    log = folder / LOG_NAME
    shutil.copyfile(SAMPLE, log)
    out = folder / "office.aion"
    result = run("build", log, "-o", out, "-q")
    assert result.exit_code == 0, result.stderr
    return out


@pytest.fixture(scope="module")
def report_dir(named_log_map: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A report written into a folder that already holds an unrelated file and a stale copy
    of one of the report's pictures, drawn by aion (both older than the run). A same-named
    file aion did not draw would be refused (tests/robustness/test_export_targets.py)."""
    from matplotlib.figure import Figure

    from aion_cli.pictures.png_mark import PNG_SOFTWARE

    out = tmp_path_factory.mktemp("out") / "report"
    out.mkdir()
    (out / "unrelated.png").write_bytes(PNG_MAGIC)
    Figure(figsize=(1, 1)).savefig(
        out / "observed.png", format="png", metadata={"Software": PNG_SOFTWARE}
    )
    for name in ("unrelated.png", "observed.png"):
        os.utime(out / name, (1_000_000_000, 1_000_000_000))
    result = run("report", named_log_map, "-o", out, "-q")
    assert result.exit_code == 0, result.stderr
    return out


def test_the_page_refers_only_to_files_this_run_wrote(report_dir: Path) -> None:
    page = _parse(report_dir / "index.html")
    text = (report_dir / "index.html").read_text(encoding="utf-8")
    assert "http://" not in text
    assert "https://" not in text
    assert "script" not in page.tags  # no script
    assert "link" not in page.tags  # the CSS is inline
    images = [r for r in page.refs if r.endswith(".png")]
    assert len(images) == 6  # the map from above, timeline, two days, a week, the roses
    for ref in page.refs:
        assert "/" not in ref, ref  # a file beside the page: no folder, no address
        assert ":" not in ref, ref
        assert not ref.startswith("."), ref
        target = report_dir / ref
        assert target.is_file(), ref
        assert target.stat().st_mtime > 1_000_000_000 + 1, f"{ref} was not written by this run"
    assert "unrelated.png" not in page.refs
    assert (report_dir / "unrelated.png").read_bytes() == PNG_MAGIC  # kept, not referenced
    assert not [p for p in report_dir.parent.iterdir() if p.name.startswith(".report.")]


def test_the_pictures_are_png_images_with_content(report_dir: Path) -> None:
    from PIL import Image

    page = _parse(report_dir / "index.html")
    for ref in (r for r in page.refs if r.endswith(".png")):
        path = report_dir / ref
        assert path.read_bytes()[:8] == PNG_MAGIC, ref
        with Image.open(path) as image:
            image.verify()
        with Image.open(path) as image:
            pixels = np.asarray(image.convert("RGB"), dtype=np.float64)
        assert min(pixels.shape[:2]) > 100, ref
        assert pixels.std() > 5.0, f"{ref} is blank"


def test_a_robot_map_draws_no_fixed_sensor_intervals(report_dir: Path) -> None:
    """The sample is observed by a robot: the timeline has the logs' span (grey) and no
    fixed-sensor bar (blue; tests/report/test_content.py checks a fixed sensor's)."""
    from PIL import Image

    with Image.open(report_dir / "observed.png") as image:
        rgb = np.asarray(image.convert("RGB"), dtype=np.float64) / 255.0
    left = rgb[:, : rgb.shape[1] // 2]  # the days panel
    blue = np.abs(left - FIXED_BLUE).max(axis=2) < 0.02
    grey = np.abs(left - np.array([0xC9, 0xD3, 0xDF]) / 255.0).max(axis=2) < 0.02
    assert blue.sum() == 0
    assert grey.sum() > 1000


def test_the_busiest_row_is_predicts_top_entry(named_log_map: Path, report_dir: Path) -> None:
    first = _parse(report_dir / "index.html").tables["busiest"][0]
    top = run_json("predict", named_log_map, "--historical", "--top", "1", "--format", "json")
    entry = top["entries"][0]
    forecast = run_json(
        "predict", named_log_map, "--time", WHEN, "--node", entry["id"], "--format", "json"
    )
    assert [first[1], first[2], first[4]] == [entry["id"], entry["kind"], f"{entry['flow']:.3f}"]
    assert first[3] == _room_of(named_log_map, entry["id"])
    assert first[6] == f"{entry['entropy']:.3f}"
    assert first[7] == f"{entry['direction_deg']:+.1f}"
    assert first[8] == forecast["entries"][0]["family"]  # the family that forecasts it
    assert first[9] == f"{entry['x']:.2f}, {entry['y']:.2f}"  # where it is


def _room_of(map_path: Path, place: str) -> str:
    """``"R1 hallway"``: the room holding ``place`` in the map's scene graph, read directly."""
    from aion_cli.engine.node_ids import node_label, parse_node_id
    from aion_cli.mapquery import load_map

    graph = load_map(map_path).graph
    assert graph is not None
    at = np.flatnonzero(graph.places.ids == np.uint64(parse_node_id(place)))
    room = graph.places.parent[at[0]]
    k = int(np.flatnonzero(graph.rooms.ids == room)[0])
    return f"{node_label(int(room))} {graph.rooms.labels[k]}"


def test_at_a_time_the_busiest_row_is_predicts_top_entry_then(
    named_log_map: Path, tmp_path: Path
) -> None:
    out = tmp_path / "at"
    result = run("report", named_log_map, "-o", out, "--time", WHEN, "--tz", "UTC", "-q")
    assert result.exit_code == 0, result.stderr
    rows = _parse(out / "index.html").tables["busiest"]
    top = run_json(
        "predict", named_log_map, "--time", WHEN, "--tz", "UTC", "--top", "10", "--format", "json"
    )["entries"]
    assert [r[1] for r in rows] == [e["id"] for e in top]
    e = top[0]
    assert rows[0][4:] == [
        f"{e['flow']:.3f}",
        f"{e['flow_per_hour']:.2f}",
        f"{e['entropy']:.3f}",
        f"{e['direction_deg']:+.1f}",
        e["family"],
        f"{e['x']:.2f}, {e['y']:.2f}",
    ]
    rooms = run_json(
        "predict", named_log_map, "--layer", "rooms", "--time", WHEN, "--tz", "UTC", "--format",
        "json",
    )["entries"]
    labels = {r[3].split()[0] for r in rows if r[3] != "-"}
    assert labels <= {r["id"] for r in rooms}


def test_the_family_counts_are_infos(named_log_map: Path, report_dir: Path) -> None:
    info = run_json("info", named_log_map, "--format", "json")
    rows = _parse(report_dir / "index.html").tables["families"]
    shown = {name: (int(flow), int(direction)) for name, flow, direction in rows}
    families = info["families"]
    names = set(families["flow"]) | set(families["direction"])
    assert shown == {
        n: (families["flow"].get(n, 0), families["direction"].get(n, 0)) for n in names
    }
    counts = {
        k: int(v.replace(",", "")) for k, v in _parse(report_dir / "index.html").tables["counts"]
    }
    assert counts["detections accepted"] == info["counts"]["used"]
    assert counts["hash cells"] == info["counts"]["cells"]
    assert counts["places"] == info["counts"]["nodes"]
    assert counts["places with flow"] == info["counts"]["nodes_with_flow"]
    inputs = _parse(report_dir / "index.html").tables["inputs"]
    size = f"{SAMPLE.stat().st_size / 2**20:.1f} MiB"  # the sample's own size, in MiB
    assert inputs == [[LOG_NAME, size, info["inputs"][0]["sha256"][:12]]]


def test_the_maps_strings_are_escaped(report_dir: Path) -> None:
    text = (report_dir / "index.html").read_text(encoding="utf-8")
    assert html.escape(LOG_NAME) in text  # off&lt;i&gt;&amp;amp;&quot;ce.mcap
    assert "<i>" not in text
    assert '&amp;"' not in text


def test_bad_output_and_missing_map_exit_2(named_log_map: Path, tmp_path: Path) -> None:
    a_file = tmp_path / "taken.txt"
    a_file.write_text("keep me")
    result = run("report", named_log_map, "-o", a_file)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "is a file, not a folder")
    assert a_file.read_text() == "keep me"
    result = run("report", tmp_path / "missing.aion", "-o", tmp_path / "r")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "map file not found")
    result = run("report", named_log_map, "-o", tmp_path / "r", "--time", "not a time")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr)
    assert not (tmp_path / "r").exists()


def test_a_failure_leaves_nothing_behind(
    named_log_map: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from aion_cli.report import plots

    def broken(*args: object, **kwargs: object) -> Path:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(plots, "roses_png", broken)
    out = tmp_path / "report"
    result = run("report", named_log_map, "-o", out, "-q")
    assert result.exit_code == 2
    # a full disk inside a picture writer (PIL) names no file: the error said only "No space
    # left on device", not where; it names the report's folder now
    assert_one_line_error(result.stderr, "No space left on device", str(out))
    assert list(tmp_path.iterdir()) == []  # neither the folder nor a staging folder


def test_the_room_curves_are_predicts_room_flows(named_log_map: Path) -> None:
    """The activity curves (``flow_series``, one batch over every time) at a few of their
    times equal ``aion predict --layer rooms`` run at each time."""
    from aion_cli.engine.time_text import format_ns
    from aion_cli.mapquery import load_map
    from aion_cli.report.content import gather
    from aion_cli.timeparse import resolve_zone

    zone = resolve_zone("UTC")
    content = gather(load_map(named_log_map), named_log_map, zone, None)
    weekday, weekend, week = content.activity
    assert weekday.names[:2] == ("R1 hallway", "R0 workspace")  # the busiest rooms first
    for series, k in ((weekday, 35), (weekend, 50), (week, 100)):
        t = int(series.times_ns[k])
        rooms = run_json(
            "predict",
            named_log_map,
            "--layer",
            "rooms",
            "--time",
            format_ns(t, zone),
            "--format",
            "json",
        )["entries"]
        flows = {r["id"]: r["flow"] for r in rooms}
        for name, value in zip(series.names, series.flows[k], strict=True):
            assert value == pytest.approx(flows[name.split()[0]], rel=1e-12, abs=1e-12), name
        assert sum(series.flows[k]) == pytest.approx(sum(flows.values()), rel=1e-12)


def test_rooms_beyond_the_busiest_are_summed_into_one_line(
    named_log_map: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from aion_cli.mapquery import load_map
    from aion_cli.report import content as module
    from aion_cli.timeparse import resolve_zone

    loaded = load_map(named_log_map)
    every = module.gather(loaded, named_log_map, resolve_zone("UTC"), None).activity
    monkeypatch.setattr(module, "TOP_ROOMS", 2)
    two = module.gather(loaded, named_log_map, resolve_zone("UTC"), None).activity
    for full, cut in zip(every, two, strict=True):
        assert cut.names == (*full.names[:2], f"other rooms ({len(full.names) - 2})")
        np.testing.assert_allclose(cut.flows[:, :2], full.flows[:, :2], rtol=0, atol=0)
        np.testing.assert_allclose(cut.flows[:, 2], full.flows[:, 2:].sum(axis=1), rtol=1e-12)


def test_the_curves_mark_the_hours_no_log_observed(tmp_path: Path) -> None:
    """Each activity time is marked unobserved exactly when the map's manifest lists no
    observed profile bin at its hour of the day: a fixed sensor's 20 minutes from 08:00 UTC
    (every other hour of the day extrapolated)."""
    from aion_cli.formats.mapfile import read_manifest
    from aion_cli.mapquery import load_map
    from aion_cli.report.content import gather
    from aion_cli.timeparse import resolve_zone
    from tests.cli.logdata import write_office_log

    log, out = tmp_path / "morning.mcap", tmp_path / "morning.aion"
    write_office_log(log, graph=False, tf=False)
    assert run("build", log, "-o", out, "-q").exit_code == 0
    content = gather(load_map(out), out, resolve_zone("UTC"), None)
    observed_hours = {b % 24 for b in read_manifest(out)["families"]["observed_bins"]}
    assert observed_hours == {8}
    for series in content.activity:
        hour = (np.asarray(series.times_ns) // 3_600_000_000_000) % 24
        np.testing.assert_array_equal(series.unobserved, hour != 8)


def test_the_activity_curves_keep_to_the_clock_on_a_day_it_changes() -> None:
    """Berlin, 2026-03-29 (02:00 skipped) and 2026-10-25 (02:00-03:00 twice): the day's
    points are the wall clock's quarter hours, drawn at their clock hour. Steps of elapsed
    time from midnight had drawn every point after the change an hour off, and let the
    spring day run into Monday."""
    from datetime import date

    from aion_cli.engine.time_text import from_ns
    from aion_cli.report.content import wall_steps
    from aion_cli.report.plots import _clock_hours
    from aion_cli.timeparse import resolve_zone

    zone = resolve_zone("Europe/Berlin")
    spring = wall_steps(date(2026, 3, 29), zone, 900, 86_400)
    assert spring.size == 92  # 02:00..02:45 do not exist that day
    hours = _clock_hours(spring, zone)
    expected = [q / 4 for q in range(96) if not 8 <= q < 12]
    assert hours.tolist() == expected
    assert from_ns(int(spring[-1]), zone).isoformat() == "2026-03-29T23:45:00+02:00"
    autumn = wall_steps(date(2026, 10, 25), zone, 900, 86_400)
    assert autumn.size == 96
    assert _clock_hours(autumn, zone).tolist() == [q / 4 for q in range(96)]
    assert from_ns(int(autumn[-1]), zone).isoformat() == "2026-10-25T23:45:00+01:00"
    week = wall_steps(date(2026, 10, 19), zone, 3600, 7 * 86_400)  # the week of the change
    assert _clock_hours(week, zone).tolist() == list(range(168))


def test_the_busiest_count_is_the_maps_places_and_cells_not_its_entries(
    office: Office, tmp_path: Path
) -> None:
    """The small office: 7 places (p5, p6 beyond the sensor's range hold no entry), no hash
    cell, 5 entries. The busiest table said "The 7 busiest of 7 entries" two lines below
    "entries 5"; the 7 are predict's rows, the map's places and hash cells."""
    out = tmp_path / "report"
    result = run("report", office.map, "-o", out, "-q")
    assert result.exit_code == 0, result.stderr
    page = _parse(out / "index.html")
    counts = dict(page.tables["counts"])
    assert (counts["places"], counts["hash cells"]) == ("7", "0")
    assert counts["entries"] == "5 (+2 places without data)"  # as info and compact say it
    rows = run_json("predict", office.map, "--historical", "--format", "json")["entries"]
    assert len(rows) == 7
    flowing = sum(1 for r in rows if (r["flow"] or 0) > 0)
    assert 0 < flowing < 7  # p5 and p6 hold no entry: they are listed, but nobody walked there
    text = " ".join((out / "index.html").read_text(encoding="utf-8").split())
    assert f"The {flowing} busiest of the map's 7 places and hash cells," in text
    assert "of 7 entries" not in text
    assert len(page.tables["busiest"]) == flowing  # places without flow are not 'busiest'


def test_a_short_span_reads_as_info_gives_it(tmp_path: Path) -> None:
    """A 10-s recording of the small office (messages at 0 and 5 s): the page's time span
    read "(0.0 h)" where aion info says "5.0 s"; it now gives info's span text, as it does
    for a long map ("5d00h" for the sample, not "120.0 h")."""
    from tests.cli.logdata import write_office_log

    log = tmp_path / "tiny.mcap"
    write_office_log(log, duration_s=10)
    built = tmp_path / "tiny.aion"
    assert run("build", log, "-o", built, "-q").exit_code == 0
    span = run_json("info", built, "--format", "json")["time_span"]
    assert span["end_ns"] - span["start_ns"] == 5 * 10**9
    assert "5.0 s:" in run("info", built).stdout
    out = tmp_path / "report"
    result = run("report", built, "-o", out, "-q")
    assert result.exit_code == 0, result.stderr
    facts = dict(_parse(out / "index.html").tables["facts"])
    assert facts["time span"].endswith("08:00:05+00:00 (5.0 s)"), facts["time span"]


def test_a_weekend_curve_of_a_map_of_weekdays_says_it_follows_the_weekdays(
    sample_map: Path,
) -> None:
    """The bundled sample holds Mon 2026-01-05 .. Fri 2026-01-09 only: the report's Saturday
    curve (of the week after the data) is the weekdays' rhythm, drawn as a forecast like any
    other with nothing saying so, while `aion predict` at that Saturday warns. The report
    carries the same note for that curve, and none for the Monday's."""
    from aion_cli.mapquery import load_map
    from aion_cli.report.content import gather
    from aion_cli.timeparse import resolve_zone

    content = gather(load_map(sample_map), sample_map, resolve_zone("UTC"), None)
    assert [s.title for s in content.activity[:2]] == ["Monday 2026-01-12", "Saturday 2026-01-17"]
    result = run("predict", sample_map, "--time", "2026-01-17 12:00", "--top", "1")
    (warned,) = [line for line in result.stderr.splitlines() if "no weekend day" in line]
    days = [n for n in content.notes if n.startswith(("Monday", "Saturday"))]
    assert days == [f"Saturday 2026-01-17: {warned}"]


@pytest.mark.parametrize(
    ("when", "seen"), [("2026-11-30 07:00", False), ("2026-11-30 08:05", True)]
)
def test_a_report_at_an_hour_no_log_observed_says_its_busiest_and_map_are_extrapolated(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, when: str, seen: bool
) -> None:
    """Before: ``report --time 07:00`` on the office map (observed 08:00-08:20 UTC) listed the
    busiest entries "predicted at 07:00" and drew the map titled with the time alone, as at an
    hour observed; only the activity curves' grey bands said which hours were extrapolated.
    Now the page's time, the busiest table's sentence and the map's title say it in the words
    of ``predict --time``'s table, which ``predict --format json`` agrees with; not at 08:05."""
    out = tmp_path / "report"
    texts = figure_texts(monkeypatch, "report", office.map, "-o", out, "--time", when, "--tz",
                         "UTC", "-q")
    doc = run_json("predict", office.map, "--time", when, "--tz", "UTC", "--format", "json")
    assert doc["hour_observed"] is seen
    page = " ".join(html.unescape((out / "index.html").read_text()).split())
    mark = f"predicted at {doc['time']} (extrapolated: an hour no log observed)"
    assert page.count(mark) == (0 if seen else 2)  # the page's time, the busiest sentence
    assert f"predicted at {doc['time']}" in page
    (text,) = [t for t in texts if t.startswith("office.aion") or " office.aion " in t]
    assert f"Mon 2026-11-30 {when[-5:]} UTC" in text
    assert ("(extrapolated: an hour no log observed)" in text) is not seen
