"""The vectorised /tf encoder produces exactly the log writer's own bytes (ROS 1 and ROS 2)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats.writers import LogWriter
from aion_cli.sim.messages import TF_MESSAGE, tf_message
from aion_cli.sim.tfcodec import TfEncoder


@pytest.mark.parametrize("container", ["mcap", "bag"])
def test_encoder_matches_the_writer_serializer(tmp_path: Path, container: str) -> None:
    rng = np.random.default_rng(1)
    n = 40
    t_ns = 1_767_600_000_000_000_000 + np.sort(rng.integers(0, 10**13, n))
    a = rng.normal(scale=20, size=(n, 3))
    b = rng.normal(scale=20, size=(n, 3))
    with LogWriter(tmp_path / "x", container) as log:
        rows = TfEncoder(log).encode(t_ns, a, b)
        for i in range(n):
            want = log.serialize(TF_MESSAGE, tf_message(int(t_ns[i]), a[i], b[i]))
            assert rows[i].tobytes() == want
