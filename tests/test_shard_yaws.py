"""The parallel build's plan of the orientation rule (aion_cli.shard_yaws): by when each
detection topic's pose orientations varied, and which shards start with that known."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import aion_cli.shard_yaws as shard_yaws
from aion_cli.build_options import build_topics
from aion_cli.formats.logs import open_logs
from aion_cli.pipeline import BuildOptions
from aion_cli.shard_yaws import shard_seeds, varied_by
from tests.cli.logdata import T0, S
from tests.time_shard_logs import HOUR_S, standing_log


def _varied(log: Path) -> dict[str, int]:
    opts = BuildOptions(logs=(log,), output=log.with_suffix(".aion"))
    with open_logs([log], None) as logset:
        return varied_by(logset, build_topics(logset, opts), opts)


def test_the_time_of_the_first_message_that_varies(tmp_path: Path) -> None:
    # one person facing one way for 20 minutes (alike), then two facing apart an hour later:
    # the first message of the second session (5 s after its start) is where they vary
    log = standing_log(tmp_path / "log.mcap", [(0, [0.7]), (HOUR_S, [0.0, 1.5])])
    assert _varied(log) == {"/tracks": T0 + (HOUR_S + 5) * S}


def test_orientations_that_never_vary_are_left_out(tmp_path: Path) -> None:
    log = standing_log(tmp_path / "log.mcap", [(0, [0.7]), (HOUR_S, [0.7])])
    assert _varied(log) == {}


def test_the_scan_reads_the_first_messages_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # 120 alike messages come first: a scan of 100 never reaches the variation
    log = standing_log(tmp_path / "log.mcap", [(0, [0.7]), (HOUR_S, [0.0, 1.5])])
    monkeypatch.setattr(shard_yaws, "SCAN_MESSAGES", 100)
    assert _varied(log) == {}
    monkeypatch.setattr(shard_yaws, "SCAN_MESSAGES", 121)
    assert _varied(log) == {"/tracks": T0 + (HOUR_S + 5) * S}


def test_shards_after_the_variation_start_with_it() -> None:
    seeds = shard_seeds({"/a": 7, "/b": 3}, [0, 5, 7, 10, None])
    assert [sorted(seed) for seed in seeds] == [[], ["/b"], ["/b"], ["/a", "/b"], []]
    assert all(math.isnan(v) for seed in seeds for v in seed.values())
