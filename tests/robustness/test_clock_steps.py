"""A recording whose clock stepped back (an NTP correction of ten minutes mid-log): its
log times go back between chunks, and the minutes it covers twice are read together in time
order, so the people seen then count twice. The build did that without a word; now the
log's reader warns (from the chunk indexes of an MCAP file, the chunk infos of a ROS 1 bag: a
step inside one chunk is not seen), in ``aion build`` and ``aion info``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.robustness.conftest import T0, Message, S, build_json, person, run

N = 1800  # one message a second: 15 minutes, then the clock goes back 10 minutes, 15 more
STEP_S = 600


CONTAINERS = pytest.mark.parametrize("container", ["mcap", "bag"])


def write_chunked(path: Path, messages: list[Message], container: str) -> Path:
    """``messages`` in the given order, in small chunks (4 KiB: about 20 messages each)."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path, container, chunk_size=4096) as writer:
        for topic, msgtype, msg, t_ns in messages:
            writer.write(topic, msgtype, msg, t_ns)
    return path


def stepped(step_s: int) -> list[Message]:
    """The person messages with the clock stepped by ``step_s`` (negative: back) halfway."""
    return [
        person(T0 + (k + (step_s if k >= N // 2 else 0)) * S, (2.1, 0.1, 0.0)) for k in range(N)
    ]


def steps_back(warnings: list[str]) -> list[float]:
    """The minutes each 'log times go back' warning names."""
    return [
        float(m.group(1))
        for w in warnings
        if (m := re.search(r"its log times go back at least ([0-9.]+) min", w)) is not None
    ]


@CONTAINERS
def test_log_times_stepping_back_are_a_warning(tmp_path: Path, container: str) -> None:
    log = write_chunked(tmp_path / f"back.{container}", stepped(-STEP_S), container)
    report = build_json(log, "-o", tmp_path / "back.aion")
    (minutes,) = steps_back(report["warnings"])
    # the step is 10 min; chunk bounds can only make it look smaller, by a chunk's 20 s
    assert 10 - 0.5 <= minutes <= 10
    assert report["detections"]["used"] == N  # what the warning is about: all are used
    info = run("info", log)
    assert info.exit_code == 0
    assert len(steps_back(info.stderr.splitlines())) == 1


@CONTAINERS
def test_log_times_in_order_or_stepping_forward_are_no_warning(
    tmp_path: Path, container: str
) -> None:
    for name, messages in (("ordered", stepped(0)), ("forward", stepped(3600))):
        log = write_chunked(tmp_path / f"{name}.{container}", messages, container)
        report = build_json(log, "-o", tmp_path / f"{name}.aion")
        assert steps_back(report["warnings"]) == [], report["warnings"]


@CONTAINERS
def test_a_log_written_out_of_time_order_builds_the_ordered_map_and_says_both_causes(
    tmp_path: Path, container: str
) -> None:
    """Messages of one topic written in shuffled order look like clock steps from the chunks'
    time ranges, yet build the map of the same messages written in order: the warning names
    both causes, not only a clock that stepped back."""
    import random

    from tests.robustness.conftest import assert_same_arrays, map_arrays

    ordered = stepped(0)
    shuffled = list(ordered)
    random.Random(2).shuffle(shuffled)
    build_json(
        write_chunked(tmp_path / f"o.{container}", ordered, container), "-o", tmp_path / "o.aion"
    )
    report = build_json(
        write_chunked(tmp_path / f"s.{container}", shuffled, container), "-o", tmp_path / "s.aion"
    )
    (warning,) = [w for w in report["warnings"] if "its log times go back at least" in w]
    assert "or the messages were written out of time order" in warning
    assert_same_arrays(map_arrays(tmp_path / "s.aion"), map_arrays(tmp_path / "o.aion"))
