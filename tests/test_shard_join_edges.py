"""Parallel builds and merged part maps at the edges a sweep of ``aion build``'s options found:
each variant must give the map of ``--workers 1`` (``aion_cli.engine.compare.differences``).

Logs: ``tests/cli/logdata.py`` (a robot at a fixed pose, people at fixed spots, the office
graph in every scene-graph message).
"""

from __future__ import annotations

from pathlib import Path

from aion_cli.engine.compare import differences
from aion_cli.mapquery import load_map
from tests.cli.conftest import run
from tests.cli.logdata import write_office_log

HOUR_S = 3600


def _same(a: Path, b: Path) -> list[str]:
    return differences(load_map(a, writable=True).state, load_map(b, writable=True).state)


def _built(logs: list[Path], out: Path, *args: object) -> Path:
    result = run("build", *logs, "-o", out, "-q", *args)
    assert result.exit_code == 0, result.output
    return out


def test_a_log_shorter_than_a_window_later_the_same_day_joins_into_that_day(
    tmp_path: Path,
) -> None:
    # the second log lies inside one window: its shard recorded only its open window, on the
    # day the first log's windows are pending; the join closed that day as if it had ended
    first, second = tmp_path / "morning.mcap", tmp_path / "noon.mcap"
    write_office_log(first, duration_s=1200)
    write_office_log(second, shift_s=2 * HOUR_S, duration_s=300)
    logs = [first, second]
    seq = _built(logs, tmp_path / "seq.aion", "--workers", "1")
    assert _same(seq, _built(logs, tmp_path / "par.aion", "--workers", "2")) == []
    parts = [_built([log], tmp_path / f"{log.stem}.part.aion", "--part") for log in logs]
    merged = tmp_path / "merged.aion"
    assert run("merge", *parts, "-o", merged, "-q").exit_code == 0
    assert _same(seq, merged) == []


def test_a_map_built_with_config_and_tz_continues_with_the_same_options(tmp_path: Path) -> None:
    # the config file's zone is the default, replaced by --tz: the continuation compared the
    # file as read (UTC) with the map's config (Europe/London) and refused the same options
    first, second = tmp_path / "mon.mcap", tmp_path / "tue.mcap"
    write_office_log(first)
    write_office_log(second, shift_s=24 * HOUR_S)
    config = tmp_path / "model.toml"
    printed = run("build", "--print-config")
    config.write_text(printed.output.replace("window_s = 600.0", "window_s = 1200.0"))
    opts = ("--config", config, "--tz", "Europe/London")
    seq = _built([first, second], tmp_path / "seq.aion", *opts)
    _built([first], tmp_path / "cont.aion", *opts)
    cont = _built([second], tmp_path / "cont.aion", "--map", tmp_path / "cont.aion", *opts)
    assert _same(seq, cont) == []
    other = config.read_text().replace("window_s = 1200.0", "window_s = 600.0")
    config.write_text(other)
    refused = run("build", second, "--map", seq, "-o", tmp_path / "x.aion", *opts)
    assert refused.exit_code == 2
    assert "--config differs" in refused.output
    # it named no parameter (merge names them): now the map's value, then the file's
    assert "(map vs --config: window_s 1200.0 vs 600.0)" in refused.output


def test_a_graph_file_keeps_the_time_one_pass_gives_it(tmp_path: Path) -> None:
    # --graph FILE is added at a build's first log, and again by each shard, continued build
    # and part: the maps held the same graph stamped with the last of those starts
    from tests.cli.logdata import save_graph_file

    graph = save_graph_file(tmp_path / "dsg.json")
    logs = []
    for k, day in enumerate((0, 1, 3)):
        log = tmp_path / f"day{k}.mcap"
        write_office_log(log, shift_s=day * 24 * HOUR_S, graph=False)
        logs.append(log)
    opts = ("--graph", graph)
    seq = _built(logs, tmp_path / "seq.aion", "--workers", "1", *opts)
    assert _same(seq, _built(logs, tmp_path / "par.aion", "--workers", "2", *opts)) == []
    _built(logs[:1], tmp_path / "cont.aion", *opts)
    cont = _built(logs[1:], tmp_path / "cont.aion", "--map", tmp_path / "cont.aion", *opts)
    assert _same(seq, cont) == []
    parts = [_built([log], tmp_path / f"{log.stem}.part.aion", "--part", *opts) for log in logs]
    merged = tmp_path / "merged.aion"
    assert run("merge", *parts, "-o", merged, "-q").exit_code == 0
    assert _same(seq, merged) == []
