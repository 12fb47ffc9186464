"""Where a fixed sensor's logs start and stop recording, to a sixtieth of a window.

Known answers on a 600-s window with 10-s steps: a file recording from 125 s to 3,420 s is
the span [120, 3430), whatever pauses it holds; a time shard of it reaches the part's edges
where the file recorded beyond them; the messages the build read extend a span the index
cut short.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from aion_cli.fixed_sensor import _message_runs, recording_bounds

DELTA = 600
STEP = 10


@dataclass
class _Times:
    """What :func:`recording_bounds` reads of a ``TimeCheck``."""

    span_times: np.ndarray
    limits: tuple[int, int] | None = None


class _Logs:
    """A log set of one file whose messages lie at ``seconds``."""

    def __init__(self, seconds: list[int]) -> None:
        self.seconds = np.array(seconds, np.int64)

    def recorded_windows_by_recording(self, size: int) -> list[tuple[Any, np.ndarray]]:
        return [(None, np.unique(self.seconds // size))]


def test_runs_of_messages_start_and_end_at_their_steps() -> None:
    times = np.array([1555, 125, 700, 3055, 3061], np.int64)  # any order
    start, end = _message_runs(times, np.array([0, 1, 2, 5, 7], np.int64), DELTA, STEP)
    # windows 0-2: 125 s to 1,555 s; window 5: 3,055-3,061 s; window 7: no message, whole
    np.testing.assert_array_equal(start, [120, 3050, 4200])
    np.testing.assert_array_equal(end, [1560, 3070, 4800])


def test_a_file_is_one_span_from_its_first_message_to_its_last() -> None:
    logs = _Logs([125, 130, 700, 1555, 3301, 3420])
    starts, ends = recording_bounds(
        logs, _Times(np.zeros(0, np.int64)), np.array([0, 1, 2, 5], np.int64), DELTA
    )  # type: ignore[arg-type]
    np.testing.assert_array_equal(starts, [120])
    np.testing.assert_array_equal(ends, [3430])


def test_a_time_shard_reaches_its_edges_where_the_file_goes_on() -> None:
    logs = _Logs([125, 700, 1210, 1555, 3301, 4000])
    # the part [1200, 3600) of a file that recorded before and after it: edge to edge
    starts, ends = recording_bounds(
        logs, _Times(np.zeros(0, np.int64), (1200, 3600)), np.array([2, 5], np.int64), DELTA
    )  # type: ignore[arg-type]
    np.testing.assert_array_equal(starts, [1200])
    np.testing.assert_array_equal(ends, [3600])
    # the first part of it: from the file's first message to the part's end
    starts, ends = recording_bounds(
        logs, _Times(np.zeros(0, np.int64), (0, 1200)), np.array([0, 1], np.int64), DELTA
    )  # type: ignore[arg-type]
    np.testing.assert_array_equal(starts, [120])
    np.testing.assert_array_equal(ends, [1200])


def test_the_messages_read_extend_a_file_its_index_cuts_short() -> None:
    """The index says the file's last message is at 700 s (a spoilt chunk), the build read
    messages until 1,555 s: the span reaches 1,560 s."""
    logs = _Logs([125, 700])
    read = np.array([125, 700, 1555], np.int64)
    starts, ends = recording_bounds(
        logs, _Times(read), np.array([0, 1, 2], np.int64), DELTA
    )  # type: ignore[arg-type]
    assert int(starts.min()) == 120
    assert int(ends.max()) == 1560


class _Files:
    """A log set of several files, each with its messages at its own ``seconds``."""

    def __init__(self, *files: list[int]) -> None:
        self.files = [np.array(s, np.int64) for s in files]

    def recorded_windows_by_recording(self, size: int) -> list[tuple[Any, np.ndarray]]:
        return [(None, np.unique(s // size)) for s in self.files]


def test_the_messages_read_do_not_join_two_files_across_the_gap_between_them() -> None:
    """Two files, the first recording 125-835 s, the second 965-1,555 s: the build reads
    messages in windows 0, 1 and 2 (one run), but nothing recorded 840-960 s: window 1 is
    [600, 840) and [960, 1200), 0.8 of it (the run of messages had read as one span from
    120 s to 1,560 s, window 1 whole)."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.observation import ObservationSource

    first, second = [125, 700, 835], [965, 1555]
    logs = _Files(first, second)
    windows = np.array([0, 1, 2], np.int64)
    within = recording_bounds(
        logs, _Times(np.array(first + second, np.int64)), windows, DELTA
    )  # type: ignore[arg-type]
    source = ObservationSource()
    source.add_fixed_windows(windows, DELTA, within)
    share = source.fixed_share(windows, DELTA, ModelConfig())
    np.testing.assert_allclose(share, [0.8, 0.8, 0.6])
