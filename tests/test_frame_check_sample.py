"""``aion info``'s sample of each detection topic read in a few passes
(:func:`aion_cli.frame_check.first_of_each`) equals reading each topic on its own
(:func:`aion_cli.frame_check._first`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats.logs import open_logs
from aion_cli.formats.writers import LogWriter
from aion_cli.frame_check import _first, first_of_each

STRING = "std_msgs/msg/String"


def _write(path: Path, container: str, seed: int, topics: int, messages: int) -> list[str]:
    """Topics of very different rates (some with a few messages, some with none in the
    first half), log times with many ties (several topics at one instant)."""
    rng = np.random.default_rng(seed)
    names = [f"/cam{k}/people" for k in range(topics)]
    rate = rng.choice([0.02, 0.2, 1.0], topics)
    times = np.sort(rng.integers(1, messages // 3, messages)) * 10**6 + 10**18
    with LogWriter(path, container, chunk_size=2048) as writer:
        for i, t in enumerate(times.tolist()):
            k = int(rng.integers(topics))
            if rng.random() < rate[k] and not (k % 7 == 3 and i < messages // 2):
                writer.write(names[k], STRING, {"data": f"{k}:{i}"}, t)
    return names


def _key(msgs: list) -> list[tuple[str, int, bytes]]:
    return [(m.topic, m.log_time_ns, bytes(m.data)) for m in msgs]


@pytest.mark.parametrize("container", ["mcap", "bag"])
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("n", [1, 3, 20])
def test_first_of_each_equals_per_topic(tmp_path: Path, container: str, seed: int, n: int) -> None:
    suffix = ".mcap" if container == "mcap" else ".bag"
    names = _write(tmp_path / f"a{suffix}", container, seed, 40, 3000)
    _write(tmp_path / f"b{suffix}", container, seed + 10, 40, 1000)  # a second file, ties
    files = [tmp_path / f"a{suffix}", tmp_path / f"b{suffix}"]
    wanted = [*names, "/absent"]
    with open_logs(files) as logs:
        fast = first_of_each(logs, wanted, n)
        for topic in wanted:
            assert _key(fast[topic]) == _key(_first(logs, topic, n)), topic
    assert sum(len(v) for v in fast.values()) > n

