"""Data on stdout, messages on stderr, as a demanding user meets them: a reader that stops
early, a narrow or dumb terminal, a log file that keeps stderr."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from tests.cli.conftest import AION
from tests.cli.conftest import run as run_cli


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    return {**env, "TZ": "UTC", "AION_DEBUG": "", **extra}


def _closed_stdout(*args: str | Path) -> subprocess.CompletedProcess[str]:
    """``aion ARGS`` whose stdout is a pipe nobody reads any more (``| head`` gone)."""
    read, write = os.pipe()
    os.close(read)
    try:
        return subprocess.run(
            [str(AION), *map(str, args)],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            env=_env(),
            timeout=120,
            check=False,
        )
    finally:
        os.close(write)


@pytest.mark.parametrize(
    "args",
    [
        ("predict", "{map}", "--time", "2026-01-12 08:40", "--top", "3"),
        ("plan", "{map}", "--from", "p12", "--to", "p87", "--time", "2026-01-12 08:40"),
        ("info", "{map}"),
        ("build", "--print-config"),
        ("--help",),
    ],
)
def test_a_table_whose_reader_stopped_is_not_a_failure(
    sample_map: Path, args: tuple[str, ...]
) -> None:
    """``aion predict MAP | head``: a table (rich) or text (click) written to a closed pipe
    ended the command with exit 1 (rich's and click's reaction to a broken pipe); stdout
    closed early is not a failure: exit 0, no message."""
    proc = _closed_stdout(*(a.format(map=sample_map) for a in args))
    assert proc.returncode == 0, proc.stderr
    assert "error" not in proc.stderr


def test_a_closed_stderr_does_not_stop_the_data(sample_map: Path, tmp_path: Path) -> None:
    """stderr read by a reader that stopped (``2>&1 >out.csv | head -1``): the notes are
    lost, but the data is still written and the exit is 0; the stderr console raised a broken
    pipe, so predict wrote nothing to stdout and still exited 0."""
    out = tmp_path / "out.csv"
    read, write = os.pipe()
    os.close(read)
    try:
        with out.open("w") as stdout:
            proc = subprocess.run(
                [str(AION), "predict", str(sample_map), "--format", "csv"],
                stdout=stdout,
                stderr=write,
                env=_env(),
                timeout=120,
                check=False,
            )
    finally:
        os.close(write)
    assert proc.returncode == 0
    lines = out.read_text().splitlines()
    assert lines[0].startswith("id,")
    assert len(lines) > 100


@pytest.fixture
def narrow(monkeypatch: pytest.MonkeyPatch) -> None:
    """A 40-column terminal on stdout and stderr (rich then shrinks tables to fit)."""
    from aion_cli.cli import console as consoles

    monkeypatch.setattr(consoles, "_OUT", consoles._Console(highlight=False, width=40))
    monkeypatch.setattr(
        consoles, "_ERR", consoles._Console(stderr=True, highlight=False, width=40)
    )


@pytest.mark.parametrize(
    ("args", "whole"),
    [
        (("predict", "{map}", "--time", "2026-01-12 08:40", "--layer", "cells", "--top", "2"),
         ("c4611692615542243362", "17.25", "10.75", "▄▁█ ▄▁▁", "profile")),
        (("predict", "{map}", "--time", "2026-01-12 08:40", "--layer", "rooms"),
         ("meeting room", "18.77", "-174°", "aggregate")),
        (("predict", "{map}", "--layer", "rooms", "--from", "2026-01-12 06:00", "--to",
          "2026-01-12 09:00"), ("meeting room (R3)", "18.77")),
        (("plan", "{map}", "--from", "kitchen", "--to", "R4", "--time", "2026-01-12 08:40"),
         ("distance only", "25.5 m", "p116", "p142")),
        (("info", "{log}"), ("/spencer/perception/tracked_persons", "46,641")),
        (("info", "{map}"), ("detections used", "3,636 of 3,636")),
        (("build", "{log}", "-o", "{out}"), ("detections read", "3,636")),
    ],
)
def test_a_narrow_terminal_cuts_no_id_or_number(
    sample_map: Path, tmp_path: Path, narrow: None, args: tuple[str, ...], whole: tuple[str, ...]
) -> None:
    """On a 40-column terminal (or an 80-column one and predict's 13 columns, or TERM=dumb,
    which rich takes as 80) rich shrank every column: ids read ``c46…``, numbers ``21.…``,
    the histogram folded over three lines. A table now keeps every value whole (the terminal
    wraps its lines)."""
    from tests.cli.conftest import SAMPLE, run

    out = tmp_path / "o.aion"
    result = run(*(a.format(map=sample_map, log=SAMPLE, out=out) for a in args))
    assert result.exit_code == 0, result.stderr
    text = result.stdout + result.stderr
    assert "…" not in text
    for value in whole:
        assert value in text, value


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (("export", "{map}", "--time", "2026-01-12 08:40", "--format", "dsg", "-o",
          "{dir}/office-4d.json"), "wrote {dir}/office-4d.json: 146 places"),
        (("compact", "{map}", "-o", "{dir}/robot.aion"),
         "cannot be continued (build --map) or merged"),
        (("report", "{map}", "-o", "{dir}/report"), "file(s) to {dir}/report: open"),
        (("plan", "{map}", "--from", "kitchen", "--to", "0,0", "--time", "2026-01-12 08:40",
          "--png", "{dir}/plan.png"), "--from kitchen (R2): its place nearest the room's"),
        (("plan", "{map}", "--from", "kitchen", "--to", "0,0", "--time", "2026-01-12 08:40",
          "--png", "{dir}/plan.png"), "--to 0,0 snapped to p0"),
        (("plan", "{map}", "--from", "p12", "--to", "p87", "--time", "2026-01-12 08:40",
          "--png", "{dir}/plan-with-a-long-name-for-the-picture-of-the-paths.png"),
         "wrote {dir}/plan-with-a-long-name-for-the-picture-of-the-paths.png"),
    ],
)
def test_a_message_is_one_line_in_a_log_file(
    sample_map: Path, tmp_path: Path, narrow: None, args: tuple[str, ...], line: str
) -> None:
    """stderr kept in a file (``2> build.log``) is 80 columns to rich, a terminal may be
    narrower: a closing message (``wrote ...``, plan's snapped ends) was broken into lines
    where a word passed the width, so ``grep`` found half of it. Each message is one line;
    the terminal wraps it."""
    result = run_cli(*(a.format(map=sample_map, dir=tmp_path) for a in args))
    assert result.exit_code == 0, result.stderr
    whole = line.format(dir=tmp_path)
    assert any(whole in message for message in result.stderr.splitlines()), result.stderr


@pytest.mark.parametrize(
    ("args", "what"),
    [
        (("info", "{log}", "--suggest-mapping", "/tf", "--format", "json"), "--suggest-mapping"),
        (("build", "--print-config", "--format", "json"), "--print-config"),
    ],
)
def test_format_json_is_json_or_refused(args: tuple[str, ...], what: str) -> None:
    """``--format json`` promises a JSON document on stdout; --suggest-mapping and
    --print-config printed their TOML anyway, so ``json.loads`` failed on exit 0. The
    combination is refused (exit 2, one line), stdout stays empty."""
    from tests.cli.conftest import SAMPLE, assert_one_line_error

    result = run_cli(*(a.format(log=SAMPLE) for a in args))
    assert result.exit_code == 2
    assert result.stdout == ""
    assert_one_line_error(result.stderr)
    assert what in result.stderr


@pytest.mark.parametrize(
    ("hz", "shown"),
    [(48358 / 432000, "0.11"), (510 / 432000, "0.0012"), (2.5, "2.50"), (1 / 86400, "1.2e-05"),
     (0.0, "0.00")],
)
def test_a_slow_topic_has_a_rate(hz: float, shown: str) -> None:
    """``aion info``: a scene graph every ten minutes (510 in five days) read '0.00' Hz in the
    table and 0.001 in JSON, a topic of one message a day 0.0 in both: a number cut to
    nothing. The table gives two significant digits below 0.1 Hz, JSON three."""
    from aion_cli.cli.info_table import rate_text
    from aion_cli.formats.summary import TopicSummary

    assert rate_text(hz) == shown
    topic = TopicSummary("/t", "std_msgs/msg/String", 2, "unsupported", "cdr", hz)
    assert topic.to_dict()["rate_hz"] == float(f"{hz:.3g}")
    assert hz == 0 or topic.to_dict()["rate_hz"] > 0


@pytest.mark.parametrize(("hz", "written"), [(19.8361, 19.836), (1071.2449, 1071.245)])
def test_a_fast_topic_keeps_its_rate(hz: float, written: float) -> None:
    """``aion info --format json``: three significant digits are for a slow topic; a fast one
    keeps its three decimals as before (a 19.836 Hz camera was 19.8, a 1071.245 Hz IMU
    1070.0)."""
    from aion_cli.formats.summary import TopicSummary

    topic = TopicSummary("/t", "sensor_msgs/msg/Imu", 2, "unsupported", "cdr", hz)
    assert topic.to_dict()["rate_hz"] == written


def test_the_departures_table_names_its_day_and_zone(sample_map: Path) -> None:
    """``plan --leave``'s table listed clock times only ('08:00'), its day and zone only in the
    stderr note of the best one; stdout kept in a file did not say which day or zone. Its
    title names them, as predict's series does."""
    result = run_cli("plan", sample_map, "--from", "p12", "--to", "p87", "--leave",
                     "2026-01-12 08:00..2026-01-12 09:00", "--step", "30m", "--tz",
                     "Europe/Berlin")
    assert result.exit_code == 0, result.stderr
    assert result.stdout.splitlines()[0].startswith("departures, 2026-01-12 (Europe/Berlin)")


def test_a_scene_graph_file_name_is_shown_not_applied(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``aion info GRAPH``: the file's path (and its layer names, format, notes) went into
    the table as rich markup, so a graph saved as '[red]site.json' was titled 'site.json'
    (in red on a terminal). Shown as plain text, as info of a log or a map shows names."""
    from tests.cli.logdata import save_graph_file

    monkeypatch.chdir(tmp_path)  # the name alone, not folded over lines as a long path is
    save_graph_file(tmp_path / "[red]site\x1b[2J.json")
    result = run_cli("info", "[red]site\x1b[2J.json")
    assert result.exit_code == 0, result.stderr
    assert "[red]site\\x1b[2J.json" in result.stdout
    assert "\x1b" not in result.stdout


def test_a_converted_log_name_is_shown_not_applied(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``aion convert t.csv -o '[red]x.mcap'`` said 'wrote x.mcap' (the name's markup applied);
    the name is shown as given, as simulate and build show theirs."""
    monkeypatch.chdir(tmp_path)
    start = 1767600000 * 10**9
    rows = (f"{start + k * 500_000_000},1,{0.6 * k:.1f},0,0,0,1.2\n" for k in range(10))
    (tmp_path / "t.csv").write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n" + "".join(rows))
    result = run_cli("convert", "t.csv", "-o", "[red]x.mcap")
    assert result.exit_code == 0, result.stderr
    assert "wrote [red]x.mcap: 10 detections" in result.stderr
