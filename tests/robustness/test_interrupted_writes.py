"""Interrupted writes leave the previous output as it was: an exception or Ctrl-C in the middle
of a log (``LogWriter``, ``simulate --force``) keeps the old log byte for byte and leaves no
staging folder; log times a container cannot hold (before 1970, beyond 2262) are refused
before anything is written. The rest of the outputs' safety: ``test_outputs.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.robustness.conftest import T0, assert_one_error, person, run, walk, write_log
from tests.robustness.test_outputs import CSV_HEADER, digest, hidden, message_count

# -- interrupted writes -----------------------------------------------------------------------


class BoomError(RuntimeError):
    """Raised mid-write by a test."""


def write_then_fail(target: Path, container: str, after: int, exc: BaseException) -> None:
    """Open ``target`` for writing (replacing it) and raise ``exc`` after ``after`` messages."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(target, container, overwrite=True) as writer:
        for topic, msgtype, msg, t in walk(50, start_s=100):
            writer.write(topic, msgtype, msg, t)
            assert hidden(target.parent) != []  # the partial log lives in the staging folder
            if writer.count == after:
                raise exc


def test_an_exception_mid_write_leaves_the_previous_log(tmp_path: Path) -> None:
    for container, name in (("mcap", "a.mcap"), ("bag", "a.bag"), ("rosbag2-sqlite3", "bag2")):
        target = tmp_path / name
        write_log(target, walk(10), container)
        before = digest(target)
        with pytest.raises(BoomError):
            write_then_fail(target, container, 30, BoomError("disk on fire"))
        assert digest(target) == before, container
        assert message_count(target) == 10
    assert hidden(tmp_path) == []


def test_a_new_log_appears_complete_or_not_at_all(tmp_path: Path) -> None:
    target = tmp_path / "new.mcap"
    with pytest.raises(KeyboardInterrupt):
        write_then_fail(target, "mcap", 5, KeyboardInterrupt())
    assert not target.exists()
    assert hidden(tmp_path) == []
    write_log(target, walk(3))
    assert message_count(target) == 3
    assert hidden(tmp_path) == []


def test_simulate_force_interrupted_mid_scene_keeps_the_old_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import aion_cli.sim.writer as sim_writer

    log = tmp_path / "office.mcap"
    args = ("simulate", "-o", log, "--days", "0.02", "--quiet")
    assert run(*args).exit_code == 0
    truth = Path(f"{log}.truth.json")
    before = (digest(log), digest(truth))
    real = sim_writer.detection_message
    calls = {"n": 0}

    def failing(*a: Any, **k: Any) -> Any:
        calls["n"] += 1
        if calls["n"] == 20:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(sim_writer, "detection_message", failing)
    result = run(*args, "--force", "--seed", "7")
    assert result.exit_code == 130
    assert calls["n"] == 20
    assert (digest(log), digest(truth)) == before
    assert hidden(tmp_path) == []


def test_simulate_force_never_deletes_a_foreign_folder(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    out.mkdir()
    (out / "results.csv").write_text("a,b\n1,2\n")
    before = digest(out)
    result = run("simulate", "-o", out, "--format", "rosbag2", "--days", "0.01", "--quiet",
                 "--force")  # fmt: skip
    assert result.exit_code == 2
    assert_one_error(result.stderr, "results.csv", "not a rosbag2 folder aion wrote")
    assert digest(out) == before


# -- negative log times ----------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".mcap", ""])
def test_negative_csv_times_are_an_input_error_without_a_partial_file(
    tmp_path: Path, suffix: str
) -> None:
    csv = tmp_path / "neg.csv"
    csv.write_text(f"{CSV_HEADER}\n-1000000000,1,0,0,0,0,1\n2000000000,1,1,0,0,0,1\n")
    out = tmp_path / f"neg{suffix}"
    result = run("convert", csv, "-o", out)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "log time -1000000000 ns", "1970")
    assert not out.exists()
    assert hidden(tmp_path) == []


def test_log_times_beyond_int64_are_refused_and_nothing_is_written(tmp_path: Path) -> None:
    from aion_cli.formats.writers import LogTimeError, LogWriter

    target = tmp_path / "x.mcap"
    topic, msgtype, msg, _ = person(T0, (1.0, 0.0, 0.0))
    with LogWriter(target) as writer:
        writer.write(topic, msgtype, msg, T0)
        with pytest.raises(LogTimeError, match="2262"):
            writer.write(topic, msgtype, msg, 2**63)
        writer.abort()
    assert not target.exists()
    assert hidden(tmp_path) == []
