"""``predict --format json|csv`` (one time and a series) and ``export``'s entries files are
written from columns (``aion_cli.entry_text``): the same bytes as ``to_json`` / ``to_csv`` of
the per-entry dicts the code made before, kept here as the reference
(:func:`reference_rows` is the old ``rows_from_table``, line for line). Compared on the
office and sample maps (cells, places, rooms with names, historical), on tables given tricky
values (NaN and infinities, quotes, commas, line breaks, escapes and non-ASCII in names and
layers), on empty answers, and with blocks of a few records so block boundaries are crossed."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import aion_cli.entry_text as entry_text
from aion_cli.entry_columns import entry_columns
from aion_cli.entry_selection import chosen_entries
from aion_cli.formats.serialize import to_csv, to_json
from aion_cli.mapquery import load_map
from aion_cli.prediction_series import SERIES_CSV_KEYS, described, predict_series
from aion_cli.predictions import CSV_KEYS, KINDS, document, entry_ids, ordered_rows
from aion_cli.timeparse import parse_time
from aion_cli.timeparse import resolve_zone as zone_named
from tests.cli.conftest import Office, run

AT = "2026-11-23 08:30"
TRICKY = ['say "hi", ok', "küche ☕", "tab\tand\nnew\r\nline", "\x1b[31mred", "", "日本"]


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def reference_rows(table: Any, index: Any = None, names: Any = None) -> list[dict[str, Any]]:
    """The per-entry ``rows_from_table`` the writers replaced (the reference)."""
    from aion_cli.engine.temporal.quantiles import count_quantiles

    picked = np.arange(len(table.xyz)) if index is None else np.asarray(index, dtype=np.int64)
    d = table.descriptors if index is None else table.descriptors_of(picked)
    flow, var = np.asarray(table.flow)[picked], np.asarray(table.flow_var)[picked]
    p10, p90 = count_quantiles(flow, var, 0.1), count_quantiles(flow, var, 0.9)
    labels = entry_ids(table, picked)
    rows = []
    for i, e in enumerate(picked.tolist()):
        kind = table.kind[e]
        kind = kind if isinstance(kind, str) else KINDS.get(int(kind), str(kind))
        probabilities = d.probabilities[i]
        speeds = d.mean_speed[i]
        known = np.isfinite(speeds) & (probabilities > 0)
        mean_speed = (
            float((speeds[known] * probabilities[known]).sum() / probabilities[known].sum())
            if known.any()
            else None
        )
        angle = _finite(float(d.dominant_angle[i]))
        rows.append(
            {
                "id": str(labels[i]),
                "name": (names or {}).get(str(labels[i])),
                "kind": kind,
                "layer": str(table.layer[e]),
                "x": float(table.xyz[e, 0]),
                "y": float(table.xyz[e, 1]),
                "z": float(table.xyz[e, 2]),
                "flow": _finite(float(d.flow_per_window[i])),
                "flow_per_hour": _finite(float(d.flow_per_hour[i])),
                "flow_p10": _finite(float(p10[i])),
                "flow_p90": _finite(float(p90[i])),
                "direction_deg": None if angle is None else math.degrees(angle),
                "direction_bin": int(d.dominant_bin[i]),
                "concentration": _finite(float(d.concentration[i])),
                "entropy": _finite(float(d.entropy[i])),
                "mean_speed": mean_speed,
                "histogram": [float(p) for p in probabilities],
                "speed_per_bin": [_finite(float(s)) for s in speeds],
                "family": str(table.flow_family[e]),
                "direction_family": str(table.direction_family[e]),
            }
        )
    return rows


@pytest.fixture(params=[10**9, 7], ids=["one-block", "small-blocks"])
def blocks(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> int:
    """Blocks of every record at once, and of a record or two (tokens per block)."""
    monkeypatch.setattr(entry_text, "BLOCK_TOKENS", request.param)
    return int(request.param)


FLAG_TEXT = {True: "true", False: "false", None: None}
"""``hour_observed`` as CSV cells: as JSON writes the flag, empty (None) where not known."""


def assert_same_text(table: Any, index: Any, names: Any, t_ns: int | None) -> None:
    """Records, JSON document and CSV of the columns equal the reference's."""
    zone = zone_named("UTC")
    columns = entry_columns(table, index, names)
    old = reference_rows(table, index, names)
    assert repr(columns.records()) == repr(old)  # types, NaN and -0.0 included
    doc = document("some 'map\".aion", 8, [], t_ns, zone, True)
    new_json = "".join(entry_text.predict_json(doc, columns))
    assert new_json == to_json(document("some 'map\".aion", 8, old, t_ns, zone, True))
    for seen in (True, False, None):  # the time's flag on every row, empty when not known
        flagged = [row | {"hour_observed": FLAG_TEXT[seen]} for row in old]
        assert "".join(entry_text.predict_csv(columns, CSV_KEYS, seen)) == to_csv(
            flagged, CSV_KEYS
        )


@pytest.mark.parametrize("layer", ["all", "places", "cells", "rooms", "buildings"])
@pytest.mark.parametrize("when", [AT, None])
def test_sample_map_layers(sample_map: Path, layer: str, when: str | None, blocks: int) -> None:
    loaded = load_map(sample_map)
    t_ns = None if when is None else parse_time(when, zone_named("UTC"))
    try:
        table, _, index, names = chosen_entries(loaded, t_ns, layer, (), None)
    except Exception as exc:  # a layer the sample has none of
        pytest.skip(str(exc))
    assert_same_text(table, ordered_rows(table, index, None), names, t_ns)
    assert_same_text(table, None, names, t_ns)  # every row, in table order (export)


def tricky_table(table: Any) -> tuple[Any, dict[str, str]]:
    """``table`` with NaN / infinite positions and flows, and names, layers and families
    holding quotes, commas, line breaks, an escape sequence and non-ASCII text."""
    n = len(table)
    xyz = np.array(table.xyz, dtype=np.float64)
    xyz[0 % n, 0], xyz[1 % n, 1], xyz[2 % n, 2] = np.nan, np.inf, -np.inf
    xyz[3 % n] = [-0.0, 1e-7, 1e17]
    flow = np.array(table.flow, dtype=np.float64)
    flow[4 % n] = np.nan
    flow[5 % n] = 1e-320
    layer = np.array([TRICKY[i % len(TRICKY)] for i in range(n)], dtype=object)
    family = np.array([TRICKY[(i + 1) % len(TRICKY)] for i in range(n)], dtype=object)
    tricky = dataclasses.replace(table, xyz=xyz, flow=flow, layer=layer, flow_family=family)
    ids = [str(i) for i in entry_ids(tricky, np.arange(n))]
    names = {i: TRICKY[k % len(TRICKY)] for k, i in enumerate(ids) if k % 3}
    return tricky, names


@pytest.mark.parametrize("when", [AT, None])
def test_tricky_values(sample_map: Path, when: str | None, blocks: int) -> None:
    loaded = load_map(sample_map)
    t_ns = None if when is None else parse_time(when, zone_named("UTC"))
    table, _, index, _ = chosen_entries(loaded, t_ns, "all", (), None)
    tricky, names = tricky_table(table)
    assert_same_text(tricky, ordered_rows(tricky, index, None), names, t_ns)
    assert_same_text(tricky, None, names, t_ns)


def test_no_entries(sample_map: Path) -> None:
    loaded = load_map(sample_map)
    table, _, _, names = chosen_entries(loaded, None, "all", (), None)
    assert_same_text(table, np.zeros(0, np.int64), names, None)


@pytest.mark.parametrize("fmt", ["json", "csv"])
@pytest.mark.parametrize("layer", ["all", "cells", "rooms"])
def test_the_cli_prints_the_reference(sample_map: Path, fmt: str, layer: str) -> None:
    loaded = load_map(sample_map)
    t_ns = parse_time(AT, zone_named("UTC"))
    table, _, index, names = chosen_entries(loaded, t_ns, layer, (), None)
    old = reference_rows(table, ordered_rows(table, index, None), names)
    result = run("predict", sample_map, "--time", AT, "--tz", "UTC", "--layer", layer,
                 "--format", fmt)
    assert result.exit_code == 0, result.stderr
    if fmt == "csv":  # the sample's five days were recorded around the clock: 08:xx observed
        assert result.stdout == to_csv([r | {"hour_observed": "true"} for r in old], CSV_KEYS)
        return
    seen = result.stdout.split('"hour_observed": ')[1].startswith("true")
    doc = document(sample_map, loaded.config.bins, old, t_ns, zone_named("UTC"), seen)
    assert result.stdout == to_json(doc) + "\n"


def test_cells_map_cli(office: Office) -> None:
    """The office map (places and cells, no rooms): JSON and CSV of every layer."""
    loaded = load_map(office.map)
    t_ns = parse_time(AT, zone_named("UTC"))
    for layer in ("all", "places", "cells"):
        table, _, index, names = chosen_entries(loaded, t_ns, layer, (), None)
        old = reference_rows(table, ordered_rows(table, index, None), names)
        result = run("predict", office.map, "--time", AT, "--layer", layer, "--format", "csv")
        # the office log observed 08:00-08:20 (UTC): 08:30 lies in an hour it observed
        assert result.stdout == to_csv([r | {"hour_observed": "true"} for r in old], CSV_KEYS)


def _series(loaded: Any, names_tricky: bool) -> tuple[Any, list[str]]:
    zone = zone_named("UTC")
    start = parse_time("2026-11-23 06:00", zone)
    times = [start + k * 3_600 * 10**9 for k in range(5)]
    table = predict_series(loaded, times, "all")
    if names_tricky:  # a NaN flow, tricky names and an infinite position
        flow = table.flow.copy()
        flow[0, 1] = np.nan
        entries = [dict(e, name=TRICKY[k % len(TRICKY)]) for k, e in enumerate(table.entries)]
        entries[0]["x"] = np.inf
        table = dataclasses.replace(table, flow=flow, flow_per_hour=flow * 6.0,
                                    entries=entries, columns=None)
    labels = [f"t{k}, \"{k}\"" for k in range(len(times))] if names_tricky else [
        str(t) for t in times]
    return described(table, "a.aion", zone, labels, [True] * len(times)), labels


@pytest.mark.parametrize("tricky", [False, True])
def test_series_text(sample_map: Path, tricky: bool, blocks: int) -> None:
    table, labels = _series(load_map(sample_map), tricky)
    assert "".join(entry_text.series_json(table)) == to_json(table.to_dict())
    csv = "".join(entry_text.series_csv(table, labels, SERIES_CSV_KEYS))
    assert csv == to_csv(table.long_rows(labels), SERIES_CSV_KEYS)


def test_series_cli(sample_map: Path) -> None:
    loaded = load_map(sample_map)
    zone = zone_named("UTC")
    args = ("--from", "2026-11-23 06:00", "--to", "2026-11-23 09:00", "--tz", "UTC")
    times = [parse_time("2026-11-23 06:00", zone) + k * 3_600 * 10**9 for k in range(4)]
    table = predict_series(loaded, times, "rooms")
    from aion_cli.engine.time_text import format_ns
    from aion_cli.predictions import hour_flags

    labels = [format_ns(t, zone) for t in times]
    full = described(table, sample_map, zone, labels, hour_flags(loaded, times))
    csv = run("predict", sample_map, *args, "--layer", "rooms", "--format", "csv")
    assert csv.stdout == to_csv(full.long_rows(labels), SERIES_CSV_KEYS)
    js = run("predict", sample_map, *args, "--layer", "rooms", "--format", "json")
    assert js.stdout == to_json(full.to_dict()) + "\n"


@pytest.mark.parametrize(
    "args",
    [
        ("--historical", "--format", "json"),
        ("--historical", "--format", "csv"),
        ("--from", "2026-11-23 06:00", "--to", "2026-11-23 20:00", "--format", "json"),
    ],
)
def test_a_reader_that_stops_early_is_not_a_failure(
    sample_map: Path, args: tuple[str, ...]
) -> None:
    """``aion predict ... --format json | head``: written in chunks, the text met the closed
    pipe inside the command, where click turns a broken pipe into exit 1; aion's own rule
    (``cli.errors``: stdout closed early is not a failure) is exit 0, no message, as for the
    one write the text was before."""
    import subprocess

    from tests.robustness.conftest import AION, aion_env

    proc = subprocess.Popen(
        [str(AION), "predict", str(sample_map), *args, "--tz", "UTC"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=aion_env(),
    )
    assert proc.stdout is not None
    assert proc.stdout.read(10)
    proc.stdout.close()  # more than a pipe holds is still to come: the next write fails
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert b"error" not in err
