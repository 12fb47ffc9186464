"""``aion predict`` orders and cuts entries on arrays and formats only the rows it prints
(issue 15): ``--top N`` is the head of the full, sorted output whatever N, layer and format,
and the dicts of the rows printed are the dicts of the whole table."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.query import historical_table, predict_table
from aion_cli.mapquery import load_map
from aion_cli.predictions import ordered_rows, rows_from_table, sort_rows
from tests.cli.conftest import Office, run, run_json

WHEN = ("--time", "2026-11-23 08:30")


@pytest.mark.parametrize("layer", ["all", "places", "cells"])
@pytest.mark.parametrize("mode", [WHEN, ("--historical",)])
def test_top_n_is_the_head_of_the_full_output(office: Office, layer: str,
                                             mode: tuple[str, ...]) -> None:
    full = run_json("predict", office.map, *mode, "--layer", layer, "--format", "json")
    everyone = full["entries"]
    for top in sorted({1, 2, 5, 17, max(len(everyone), 1), len(everyone) + 3}):
        head = run_json("predict", office.map, *mode, "--layer", layer, "--top", str(top),
                        "--format", "json")
        assert head["entries"] == everyone[:top]
        csv_full = run("predict", office.map, *mode, "--layer", layer, "--format", "csv")
        csv_head = run("predict", office.map, *mode, "--layer", layer, "--top", str(top),
                       "--format", "csv")
        lines = csv_full.stdout.splitlines()
        assert csv_head.stdout.splitlines() == lines[: top + 1]


def test_array_order_is_the_dict_order_with_ties_and_unknown_flows(office: Office) -> None:
    state = load_map(office.map).state
    for table in (predict_table(state, 1_795_000_000 * 10**9), historical_table(state)):
        every = np.arange(len(table))
        rows = rows_from_table(table)
        assert rows_from_table(table, every) == rows
        expected = sort_rows(rows)
        assert rows_from_table(table, ordered_rows(table, every, None)) == expected
        for top in (1, 3, 10, len(rows)):
            assert rows_from_table(table, ordered_rows(table, every, top)) == expected[:top]
        # ties: every flow equal, then every flow unknown: the order is by id alone
        for value in (0.0, np.nan):
            flat = np.full(len(table), value)
            tied = dataclasses.replace(table, flow=flat)  # its descriptors follow the flow
            want = sorted(range(len(table)), key=lambda e: str(table.ids[e]))
            assert ordered_rows(tied, every, 4).tolist() == want[:4]


def test_described_rows_equal_the_whole_tables_rows(sample_map: Path) -> None:
    """The bundled sample's map at noon (bins its entries lack placed by their groups' and
    the map's headings, ``descriptors.PooledHeadings``): the ten busiest rows described
    alone, as ``--top 10`` describes them, and every row in any order, equal their rows of
    the whole table's descriptors, directions included, to the bit."""
    table = predict_table(load_map(sample_map).state, 1_767_960_000 * 10**9)
    assert table.placed is not None
    assert table.bin_cos is not None
    assert table.bin_sin is not None
    heading_cos = table.heading_cos
    assert heading_cos is not None
    assert (table.bin_cos != heading_cos).any()  # bins placed by groups or the map: tested
    whole = table.descriptors
    flowing = np.flatnonzero(np.nan_to_num(whole.flow_per_window) > 0)
    assert flowing.size > 10
    busiest = flowing[np.argsort(-whole.flow_per_window[flowing], kind="stable")[:10]]
    for pick in (busiest, np.arange(len(table))[::-1], np.asarray([len(table) - 1, 0])):
        part = table.descriptors_of(pick)
        for name in ("flow_per_window", "probabilities", "dominant_bin", "dominant_angle",
                     "concentration", "entropy", "mean_speed", "mean_angle"):
            got, want = getattr(part, name), getattr(whole, name)[pick]
            assert np.array_equal(got, want, equal_nan=True), name
