"""One map queried from several threads at once (a notebook's thread pool, a web server):
each answer is the CLI's, and so is every later one. Before, the first queries of a loaded map
raced to fold its pending day into its accumulators in place: they folded it more than once,
answered with other flows, and the map kept the wrong accumulators for good."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import aion_cli as aion
from tests.cli.conftest import run_json

T = "2026-01-12 08:40"  # a Monday of the bundled sample
THREADS = 6


def _at_once(m: aion.Map) -> dict[int, Any]:
    """Predictions (even threads) and observed flows (odd ones) of ``m`` from
    :data:`THREADS` threads started together; each thread's answer."""
    start = threading.Barrier(THREADS)
    answers: dict[int, Any] = {}

    def query(k: int) -> None:
        start.wait()
        table = m.predict(T, tz="UTC") if k % 2 == 0 else m.predict(historical=True)
        answers[k] = table.to_dict()

    threads = [threading.Thread(target=query, args=(k,)) for k in range(THREADS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return answers


def test_threads_querying_one_fresh_map_get_the_cli_s_answers(sample_map: Path) -> None:
    predicted = run_json("predict", sample_map, "--time", T, "--tz", "UTC", "--format", "json")
    observed = run_json("predict", sample_map, "--historical", "--format", "json")
    expected = [predicted, observed]
    for _ in range(4):  # a fresh map each time: the race was on its first queries
        m = aion.Map.load(sample_map)
        answers = _at_once(m)
        assert len(answers) == THREADS  # no thread failed
        for k, answer in answers.items():
            assert answer == expected[k % 2], k
        assert m.predict(T, tz="UTC").to_dict() == predicted  # and the map stays right
