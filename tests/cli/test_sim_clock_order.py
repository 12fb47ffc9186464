"""Logs whose log times are a simulation's clock from 0 (1970) while their messages' header
stamps are on the wall clock (2026): built together (``--workers 2``) or one added to a map of
the other with ``--map``, they were refused as "logs must be added to a map in time order",
though nobody added anything out of order: the logs are ordered by their log times, the map's
windows by the stamps. The error now gives that reason and the way out that works (one log at
a time in the order of the stamps); wall-clock logs given out of order keep the old words."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
from mcap.writer import Writer

from tests.cli.conftest import assert_one_line_error, run, run_json
from tests.cli.logdata import write_office_log

S = 1_000_000_000
DAY_S = 86_400
ORDER = "logs must be added to a map in time order"
CLOCK = "their clock is not wall time but, it seems, a simulation's clock from 0"


def _on_sim_clock(src: Path, dst: Path, start_ns: int) -> Path:
    """``src`` with its log times moved to start at ``start_ns`` (a simulation's clock), every
    message's bytes (and so its header stamp) unchanged."""
    with src.open("rb") as f, dst.open("wb") as g:
        messages = list(make_reader(f).iter_messages(log_time_order=True))
        w = Writer(g)
        w.start(profile="ros2")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        t0 = messages[0][2].log_time
        for schema, channel, m in messages:
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = w.register_channel(
                    channel.topic, channel.message_encoding,
                    schemas[schema.id] if schema is not None else 0, channel.metadata,
                )  # fmt: skip
            t = m.log_time - t0 + start_ns
            w.add_message(channels[channel.id], t, m.data, t)
        w.finish()
    return dst


def _logs(tmp_path: Path) -> tuple[Path, Path]:
    """Monday's and Tuesday's office logs (stamps a day apart), recorded on a simulation's
    clock that restarted: Monday's log times start at 5000 s, Tuesday's at 1 s."""
    monday, tuesday = tmp_path / "monday.real.mcap", tmp_path / "tuesday.real.mcap"
    write_office_log(monday)
    write_office_log(tuesday, shift_s=DAY_S)
    return (
        _on_sim_clock(monday, tmp_path / "monday.mcap", 5000 * S),
        _on_sim_clock(tuesday, tmp_path / "tuesday.mcap", 1 * S),
    )


def test_built_together_the_reason_is_the_clock(tmp_path: Path) -> None:
    monday, tuesday = _logs(tmp_path)
    out = tmp_path / "both.aion"
    result = run("build", monday, tuesday, "--workers", "2", "-o", out, "-q")
    assert result.exit_code == 2, result.stderr
    errors = [line for line in result.stderr.splitlines() if not line.startswith("warning: ")]
    assert_one_line_error("\n".join(errors), CLOCK, "monday.mcap start at 1970-01-01 01:23:20 UTC")
    assert ORDER not in result.stderr
    assert "in the order of their stamps" in result.stderr
    assert not out.exists()


def test_built_in_one_pass_the_reason_is_the_clock(tmp_path: Path) -> None:
    """--workers 1 merges the logs by their log times (Tuesday's first, from 1 s): Monday's
    detections, stamped a day before the windows Tuesday's closed, were dropped as
    before_window, 300 of 600, and the build said nothing but a count. Now it is refused
    as --workers 2 refuses it."""
    monday, tuesday = _logs(tmp_path)
    out = tmp_path / "both.aion"
    result = run("build", monday, tuesday, "--workers", "1", "-o", out, "-q")
    assert result.exit_code == 2, result.stderr
    errors = [line for line in result.stderr.splitlines() if not line.startswith("warning: ")]
    assert_one_line_error(
        "\n".join(errors),
        CLOCK,
        "monday.mcap, tuesday.mcap start at 1970-01-01 00:00:01 UTC",
        "stamped from 2026-11-23 08:00:05 UTC",  # Monday's first detection
    )
    assert ORDER not in result.stderr
    assert "in the order of their stamps" in result.stderr
    assert not out.exists()


def test_one_pass_on_a_simulation_clock_in_the_stamps_order_is_built(tmp_path: Path) -> None:
    """Logs on a simulation's clock whose log times keep the order of their stamps lose
    nothing in one pass: built, every detection used (as a build of each alone)."""
    monday, tuesday = tmp_path / "monday.real.mcap", tmp_path / "tuesday.real.mcap"
    write_office_log(monday)
    write_office_log(tuesday, shift_s=DAY_S)
    mon = _on_sim_clock(monday, tmp_path / "monday.mcap", 1 * S)
    tue = _on_sim_clock(tuesday, tmp_path / "tuesday.mcap", 10_000 * S)
    alone = [
        run_json("build", log, "-o", tmp_path / f"{log.stem}.aion", "--format", "json", "-q")
        for log in (mon, tue)
    ]
    both = run_json(
        "build", mon, tue, "--workers", "1", "-o", tmp_path / "b.aion", "--format", "json", "-q"
    )
    used = [r["detections"]["used"] for r in alone]
    assert both["detections"]["used"] == sum(used) > 0
    assert both["detections"]["dropped"].get("before_window", 0) == 0


def test_added_with_map_the_reason_is_the_clock_and_the_hint_works(tmp_path: Path) -> None:
    monday, tuesday = _logs(tmp_path)
    tue = tmp_path / "tuesday.aion"
    assert run("build", tuesday, "-o", tue, "-q").exit_code == 0
    before = tue.read_bytes()
    result = run("build", monday, "--map", tue, "-q")
    assert result.exit_code == 2, result.stderr
    errors = [line for line in result.stderr.splitlines() if not line.startswith("warning: ")]
    assert_one_line_error("\n".join(errors), CLOCK, "stamped from 2026-11-23 08:00:00 UTC")
    assert ORDER not in result.stderr
    assert tue.read_bytes() == before  # nothing was added
    # the way out the hint gives: one at a time, in the order of the stamps
    mon = tmp_path / "monday.aion"
    assert run("build", monday, "-o", mon, "-q").exit_code == 0
    added = run("build", tuesday, "--map", mon, "-q")
    assert added.exit_code == 0, added.stderr


def test_wall_clock_logs_out_of_order_keep_the_order_reason(tmp_path: Path) -> None:
    monday, tuesday = tmp_path / "monday.mcap", tmp_path / "tuesday.mcap"
    write_office_log(monday)
    write_office_log(tuesday, shift_s=DAY_S)
    tue = tmp_path / "tuesday.aion"
    assert run("build", tuesday, "-o", tue, "-q").exit_code == 0
    result = run("build", monday, "--map", tue, "-q")
    assert result.exit_code == 2
    assert ORDER in result.stderr
    assert CLOCK not in result.stderr
