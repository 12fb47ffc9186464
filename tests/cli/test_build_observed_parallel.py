"""``aion build --observed`` with workers: logs with declared spans built in parallel, and a
continued map, give the sequential build's map (its observation, its forecasts, its notes).

Split from tests/cli/test_build_observed.py."""

from __future__ import annotations

from pathlib import Path

from aion_cli.formats.mapfile import read_manifest
from tests.cli.conftest import run_json
from tests.cli.logdata import write_office_log

DAY_S = 86_400


def test_logs_with_declared_spans_build_in_parallel_to_the_same_map(tmp_path: Path) -> None:
    """Each file is a shard of its own, and each shard fills its share of the declared time
    between the files (up to the window of its last message, the next from the one after):
    the workers' map equals the sequential one (its observation, its forecast entry by
    entry, its notes)."""
    logs = []
    for k in range(3):
        log = tmp_path / f"day{k}.mcap"
        write_office_log(log, graph=False, tf=False, shift_s=k * DAY_S,
                         later_sessions_s=(4 * 3600,))  # 08:00 and 12:00, silent between
        logs.append(log)
    span = ("--observed", "2026-11-23..2026-11-27")
    one = run_json("build", *logs, "-o", tmp_path / "one.aion", "--format", "json",
                   "--workers", "1", *span)
    two = run_json("build", *logs, "-o", tmp_path / "two.aion", "--format", "json",
                   "--workers", "2", *span)
    assert len(two["workers"]) == 3
    # the span, 00:00 on the 23rd (8 h before the first file's 08:00) to 00:00 on the 27th
    # (35.7 h after the last file's 12:20): four days, 576 windows, 12 (4 per file) with
    # messages
    assert one["observation"].startswith("fixed sensor over the 576 windows")
    assert read_manifest(tmp_path / "two.aion")["observation"] == one["observation"]
    for at in ("2026-11-26 10:00", "2026-11-26 03:00"):
        a = run_json("predict", tmp_path / "one.aion", "--time", at, "--format", "json")
        b = run_json("predict", tmp_path / "two.aion", "--time", at, "--format", "json")
        assert [(e["id"], e["flow"]) for e in a["entries"]] == \
            [(e["id"], e["flow"]) for e in b["entries"]]
    # one note of the windows the spans added, the three files' summed, as one pass gives it
    # (the workers' build had listed one note per shard); the last shard fills the span's
    # windows after the last file (12:20 on the 25th to the 27th, 35.7 h: they stayed
    # unknown) and ends the map at the span's last instant, as one pass
    added = [[n for n in r["notes"] if n.startswith("--observed: ")] for r in (one, two)]
    assert added[0] == added[1] == [
        "--observed: 564 window(s) without a message taken as observed (94.0 h), the time "
        "between the logs included",
    ]
    ends = {read_manifest(tmp_path / f"{m}.aion")["time_span"]["end_ns"] for m in ("one", "two")}
    assert ends == {(1795392000 + 4 * DAY_S) * 10**9 - 1}


def test_a_continued_map_fills_the_declared_time_since_its_logs_in_parallel_too(
    tmp_path: Path,
) -> None:
    """A map of the first day (its span that day) continued with the next two, each in its
    own file, and the span of the three days: the first shard fills from the window after the
    map's reach (its span's end), so the workers' map equals the sequential continuation and
    the build of all three at once with that span."""
    logs = []
    for k in range(3):
        log = tmp_path / f"day{k}.mcap"
        write_office_log(log, graph=False, tf=False, shift_s=k * DAY_S)
        logs.append(log)
    span = ("--observed", "2026-11-23..2026-11-26")
    together = tmp_path / "together.aion"
    run_json("build", *logs, "-o", together, "--format", "json", "--workers", "1", *span)
    answers = []
    for workers in ("1", "2"):
        step = tmp_path / f"step{workers}.aion"
        run_json("build", logs[0], "-o", step, "--format", "json", "--observed",
                 "2026-11-23..2026-11-24")
        report = run_json("build", *logs[1:], "--map", step, "--format", "json",
                          "--workers", workers, *span)
        assert len(report["workers"]) == (2 if workers == "2" else 0)  # 2: one per file
        answers.append(step)
    observations = {read_manifest(p)["observation"] for p in (together, *answers)}
    # the span's 00:00 on the 23rd to 00:00 on the 26th: three days
    assert observations == {"fixed sensor over the 432 windows with messages or --observed "
                            "(432 of the 432 windows of 10 min from the first to the last)"}
    assert len({read_manifest(p)["counts"]["recording_reach"] for p in (together, *answers)}) == 1
    at = "2026-11-26 03:00"
    flows = [[(e["id"], e["flow"]) for e in run_json(
        "predict", p, "--time", at, "--format", "json")["entries"]] for p in (together, *answers)]
    assert flows[0] == flows[1] == flows[2]
