"""The report of a map whose scene graph has rooms none of which holds a navigational place
(a spark_dsg 1.1 graph whose rooms hold its 3D places while its 2D places, ``MESH_PLACES``,
are the navigational layer): its activity curves are the whole map's flow, with a note
saying why. They were drawn per room, and with no room holding a place the charts came out
empty under "one line per room" while the map held hundreds of detections.

The graph is the real Matterport3D house of Hydra-GNN (``../shared/data/dsg``), as
:mod:`tests.cli.test_rooms_off_nav_layer` writes it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.mapquery import load_map
from aion_cli.report.content import gather
from aion_cli.timeparse import resolve_zone
from tests.cli.conftest import run
from tests.cli.test_rooms_off_nav_layer import house, pytestmark  # noqa: F401  (fixture)

S = 1_000_000_000


def test_activity_is_the_whole_maps_flow_with_a_note(
    house: tuple[Path, Path, dict[str, set[str]]], tmp_path: Path  # noqa: F811
) -> None:
    from aion_cli.engine.query import predict_table

    graph, log, rooms = house
    out = tmp_path / "both.aion"
    assert run("build", log, "--graph", graph, "-o", out, "-q").exit_code == 0
    loaded = load_map(out)
    content = gather(loaded, out, resolve_zone("UTC"), None)

    assert [s.names for s in content.activity] == [("whole map",)] * 3
    assert any(f"none of the scene graph's {len(rooms)} rooms" in n for n in content.notes)
    weekday = content.activity[0]
    for k in (0, 50, 95):
        t = int(weekday.times_ns[k])
        total = float(np.nansum(predict_table(loaded.state, t).flow))
        assert total > 0
        assert weekday.flows[k, 0] == pytest.approx(total, rel=1e-12, abs=1e-12)
