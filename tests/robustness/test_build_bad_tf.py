"""``aion build`` on logs with undecodable ``/tf`` messages (issue 14): one bad message is
skipped and counted, not the end of the build (the map equals the clean log's); a log none of
whose ``/tf`` messages decode is exit 2, not quietly a fixed-sensor map.

Logs are written with ``formats.writers.LogWriter`` (tests/robustness/conftest.py helpers);
the garbage payloads are placed with ``tests/robustness/mcap_edit.py``.
"""

from __future__ import annotations

from pathlib import Path

from tests.robustness.conftest import (
    T0,
    Message,
    S,
    assert_same_arrays,
    build_json,
    fails,
    map_arrays,
    robot_tf,
    run,
    walk,
    write_log,
)
from tests.robustness.mcap_edit import copy_with


def robot_log(seconds: int = 1200) -> list[Message]:
    """People near (2.1, 0.1) every second, the robot's TF every 5 s."""
    msgs = [*walk(seconds), *(robot_tf(T0 + k * S) for k in range(0, seconds, 5))]
    return sorted(msgs, key=lambda m: m[3])


GARBAGE_TF = b"\x00\x01\x00\x00\xff\xff\xff\x7f"  # a CDR TFMessage claiming 2**31 transforms


def test_one_undecodable_tf_message_is_skipped_and_counted(tmp_path: Path) -> None:
    """Before: one bad /tf message stopped the whole build (exit 2)."""
    clean = write_log(tmp_path / "clean.mcap", robot_log())
    bad = copy_with(clean, tmp_path / "bad.mcap", [("/tf", "", GARBAGE_TF, T0 + 602 * S + 1)])
    build_json(clean, "-o", tmp_path / "clean.aion")
    report = build_json(bad, "-o", tmp_path / "bad.aion")
    assert report["tf_undecodable"] == 1
    warning = next(w for w in report["warnings"] if "/tf" in w)
    assert warning.startswith(
        "1 of 241 messages on /tf could not be decoded and were skipped (first: cannot decode"
    )
    assert report["observation"] == "tf map->base_link"
    assert_same_arrays(map_arrays(tmp_path / "bad.aion"), map_arrays(tmp_path / "clean.aion"))


def test_a_log_whose_tf_is_all_undecodable_is_exit_2(tmp_path: Path) -> None:
    """Without any TF the map would quietly turn into a fixed-sensor map: an error instead."""
    clean = write_log(tmp_path / "clean.mcap", robot_log(300))
    bad = copy_with(clean, tmp_path / "bad.mcap", replace={"/tf": GARBAGE_TF})
    fails(run("build", bad, "-o", tmp_path / "m.aion"), "none of the 60 messages on /tf")
    assert not (tmp_path / "m.aion").exists()
