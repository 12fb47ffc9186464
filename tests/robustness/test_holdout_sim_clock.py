"""``aion evaluate holdout`` of a wall-clock map on test logs on a simulation's clock from 0
(1970): the warning of the simulation's clock is about the test logs, not the map.

Before, the held-out logs were read by the build's own reading, which warned "the map's data
starts at 1970-01-01 ..." of the test logs' first message, and told to query the map at 1970
times, while the map judged held data of 2026."""

from __future__ import annotations

import json
from pathlib import Path

from aion_cli.stamp_warnings import SIM_TIME
from tests.robustness.conftest import T0, S, build_json, person, run, write_log

N = 300


def test_the_sim_clock_warning_of_a_holdout_names_the_test_logs(tmp_path: Path) -> None:
    people = [person(T0 + k * S, (2.1, 0.1, 0.0)) for k in range(N)]
    wall = write_log(tmp_path / "wall.mcap", people)
    site = tmp_path / "wall.aion"
    assert all(SIM_TIME not in w for w in build_json(wall, "-o", site)["warnings"])
    on_sim = [person((100 + k) * S, (2.1, 0.1, 0.0)) for k in range(N)]  # from 00:01:40 UTC
    sim = write_log(tmp_path / "sim.mcap", on_sim)
    result = run("evaluate", "holdout", site, sim, "--format", "json")
    assert result.exit_code == 0, result.stderr
    warned = [w for w in json.loads(result.stdout)["warnings"] if SIM_TIME in w]
    assert len(warned) == 1, warned
    said = "the test logs' data starts at 1970-01-01 00:01:40 UTC (a Thursday)"
    assert warned[0].startswith(said)
    assert "aion predict" not in warned[0]  # the map is not on that clock: nothing to query
    assert not any(w.startswith("the map's data") for w in json.loads(result.stdout)["warnings"])
