"""The build writes its manifest through the typed :class:`aion_cli.manifest.Manifest` and reads
a continued map's the same way; the stored JSON keeps the keys, their order and their values of
the dict the build wrote before (``formats.mapfile.read_manifest``), and ``aion info`` shows
the same document as before (the stored keys without ``members`` and ``state``).

Before/after check done by hand when the manifest became typed: the manifests of a new map
(with ``--graph FILE``), of that map continued by a second log, and of a map with ``--tz`` were
equal key for key and value for value (``created`` aside)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.cli.info_map import describe_map
from aion_cli.engine.types import DetectionBatch
from aion_cli.formats.mapfile import read_manifest, read_map
from aion_cli.formats.tracks_log import tracks_to_log
from aion_cli.manifest import Manifest
from aion_cli.pipeline import BuildOptions, build_map

S = 1_000_000_000
HOUR = 3600 * S
DAY = 24 * HOUR
T0 = 1_762_070_400 * S  # aligned to 10-minute windows
GRAPH = Path(__file__).parent / "data" / "dsg" / "apartment_dsg.json"

#: The keys of a map's manifest as the build wrote them before the typed manifest, in order.
STORED_KEYS = [
    "format",
    "version",
    "creator",
    "created",
    "state",
    "config",
    "inputs",
    "time_span",
    "counts",
    "last_build",
    "graph_source",
    "observation",
    "timezone",
    "families",
    "map_frame",  # since 2026-12-05: the frame the positions are in
    "recordings",  # since 2026-12-07: each build's logs and a sample of their detections
    "derived",  # since 2026-12-08: the seal of the derived members (aion_cli.derived_seal)
    "members",
]
CONTAINER_KEYS = ("format", "version", "creator", "created", "members")


def _people(start: int, n: int = 60) -> DetectionBatch:
    t = start + np.arange(n) * (HOUR // n)
    xy = np.column_stack([np.linspace(0.0, 3.0, n), np.zeros(n), np.zeros(n)])
    return DetectionBatch.from_arrays(t, xy, np.zeros(n), np.ones(n), np.arange(n) % 3)


def _logs(folder: Path) -> list[Path]:
    logs = []
    for k, start in enumerate((T0, T0 + 2 * DAY)):
        log = folder / f"day{k}.mcap"
        tracks_to_log(_people(start), log, observed=[(start, start + HOUR)])
        logs.append(log)
    return logs


def _old_describe(path: Path) -> dict[str, Any]:
    """What ``aion info MAP`` showed before the typed manifest (the samples of the logs'
    detections, ``recordings``, and the seal of the derived members, ``derived``, written
    since, are not shown: kilobytes of base64, digests)."""
    manifest = read_manifest(path)
    hidden = ("members", "state", "recordings", "derived")
    return {"map": str(path)} | {k: v for k, v in manifest.items() if k not in hidden}


@pytest.fixture(scope="module")
def maps(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    folder = tmp_path_factory.mktemp("manifest")
    logs = _logs(folder)
    first = build_map(BuildOptions(logs=(logs[0],), output=folder / "a.aion", graph_file=GRAPH))
    first_manifest = read_manifest(first.output)
    second = build_map(
        BuildOptions(logs=(logs[1],), output=folder / "a.aion", continue_from=first.output)
    )
    zoned = build_map(
        BuildOptions(logs=(logs[0],), output=folder / "z.aion", timezone="Europe/Berlin")
    )
    return {
        "logs": logs,
        "first": first,
        "first_manifest": first_manifest,
        "second": second,
        "zoned": zoned,
    }


def test_the_stored_manifest_has_the_keys_of_before_in_their_order(maps: dict[str, Any]) -> None:
    for report in (maps["second"], maps["zoned"]):
        assert list(read_manifest(report.output)) == STORED_KEYS
    assert list(maps["first_manifest"]) == STORED_KEYS


def test_the_stored_manifest_round_trips_through_the_typed_one(maps: dict[str, Any]) -> None:
    for stored in (maps["first_manifest"], read_manifest(maps["second"].output)):
        fields = {k: v for k, v in stored.items() if k not in CONTAINER_KEYS}
        typed = Manifest.from_dict(stored)
        assert typed.to_dict() == fields
        assert list(typed.to_dict()) == list(fields)


def test_the_values_are_those_the_build_wrote_before(maps: dict[str, Any]) -> None:
    first, second = maps["first"], maps["second"]
    old = maps["first_manifest"]
    assert old["inputs"] == first.inputs  # path, name, size, sha256 as provenance gives them
    assert old["time_span"] == {"start_ns": first.start_ns, "end_ns": first.end_ns}
    assert old["last_build"] == first.to_dict()["detections"]
    assert old["counts"]["read"] == old["counts"]["used"] == 60
    assert old["graph_source"] == f"file {GRAPH.name}"
    assert old["timezone"] == "UTC"
    new = read_manifest(second.output)
    assert new["inputs"] == old["inputs"] + second.inputs  # the continued map's first
    assert new["time_span"] == {"start_ns": first.start_ns, "end_ns": second.end_ns}
    assert second.start_ns == first.start_ns  # joined with the continued map's span
    assert new["counts"]["read"] == new["counts"]["used"] == 120  # over both builds
    assert new["counts"]["dropped"] == {}
    assert new["last_build"] == second.to_dict()["detections"]
    assert new["graph_source"] == "continued map"
    assert read_manifest(maps["zoned"].output)["timezone"] == "Europe/Berlin"


def test_info_shows_what_it_showed_before(maps: dict[str, Any]) -> None:
    """Everything the manifest showed, in the same order; the graph's rooms and buildings and
    the layer its places came from after it, the entries and the places without any, and the
    warnings of what could not be read (none for these maps)."""
    for report in (maps["first"], maps["second"], maps["zoned"]):
        shown = describe_map(report.output)
        assert shown.pop("warnings") == []
        rooms = shown.pop("rooms")
        buildings = shown.pop("buildings", [])
        layer = shown.pop("nav_layer", None)
        entries, without = shown.pop("entries"), shown.pop("places_without_data")
        assert shown == _old_describe(report.output)
        assert list(shown) == list(_old_describe(report.output))
        assert isinstance(rooms, list)
        assert isinstance(buildings, list)
        assert layer is None or isinstance(layer, str)
        # the entry counts came after it: one per row of the map's entries, and the places
        # without any
        assert entries == len(read_map(report.output)[0]["entry_kind"])
        assert without >= 0


def test_a_log_the_continued_map_holds_is_refused_by_its_typed_inputs(
    maps: dict[str, Any], tmp_path: Path
) -> None:
    from aion_cli.errors import InputError

    with pytest.raises(InputError, match="already in the map"):
        build_map(
            BuildOptions(
                logs=(maps["logs"][0],),
                output=tmp_path / "again.aion",
                continue_from=maps["second"].output,
            )
        )


def test_a_continued_builds_span_is_widened_to_the_maps() -> None:
    old = Manifest.from_dict({"state": {}, "time_span": {"start_ns": 100, "end_ns": 200}})
    assert old.joined_span(150, 300) == (100, 300)
    assert old.joined_span(50, 120) == (50, 200)
    assert old.joined_span(None, None) == (100, 200)  # no message used: the map's own span
    empty = Manifest.from_dict({"state": {}, "time_span": {}})
    assert empty.joined_span(None, 7) == (None, 7)


def test_recording_windows_add_up_while_every_part_has_them() -> None:
    """``counts.recording_windows`` sums over builds and merges; a part without it (an older
    map, a robot's) or with a damaged value drops it rather than understate the logs' time."""
    from aion_cli.manifest import add_counts

    part = {"read": 3, "used": 3, "dropped": {}}
    first = add_counts({}, part | {"recording_windows": 10})
    assert first["recording_windows"] == 10
    assert add_counts(first, part | {"recording_windows": 4})["recording_windows"] == 14
    assert "recording_windows" not in add_counts(first, part)  # the new part has none
    older = {"read": 1, "used": 1, "dropped": {}}
    assert "recording_windows" not in add_counts(older, part | {"recording_windows": 4})
    damaged = first | {"recording_windows": "ten"}
    assert "recording_windows" not in add_counts(damaged, part | {"recording_windows": 4})
    assert add_counts(first, part | {"recording_windows": 4})["read"] == 6


def test_a_merge_counts_the_window_two_maps_meet_in_once() -> None:
    """``add_counts(meet=True)``: one map's last recorded window being the other's first is
    counted once, in either order; maps apart, or an older map without ``recording_first``
    (unknown), add as they are; a continued build (no ``meet``) has left it out already."""
    from aion_cli.manifest import add_counts

    part = {"read": 3, "used": 2, "dropped": {}}
    a = add_counts({}, part | {"recording_windows": 4, "recording_first": 10})
    a["recording_reach"] = 13
    b = part | {"recording_windows": 2, "recording_first": 13, "recording_reach": 14}
    assert add_counts(a, b, meet=True)["recording_windows"] == 5
    assert add_counts(add_counts({}, b), a, meet=True)["recording_windows"] == 5
    both = add_counts(a, b, meet=True)
    assert (both["recording_first"], both["recording_reach"]) == (10, 14)
    assert add_counts(a, b)["recording_windows"] == 6
    later = b | {"recording_first": 20, "recording_reach": 21}
    assert add_counts(a, later, meet=True)["recording_windows"] == 6
    older = {k: v for k, v in a.items() if k != "recording_first"}
    assert add_counts(older, b, meet=True)["recording_windows"] == 6
    assert "recording_first" not in add_counts(older, b, meet=True)


def test_a_part_maps_observed_spans_round_trip_and_a_damaged_value_is_a_corrupt_map() -> None:
    """``observed_spans`` (a part map's ``--observed`` spans, which ``aion merge`` fills the
    time between parts from): read back as written, left out when empty, and a value that is
    not a list of [start_ns, end_ns] integer pairs is a corrupt map (exit 2), not a crash."""
    from aion_cli.errors import MapCorruptError
    from aion_cli.manifest import part_spans

    spans = [[100, 200], [300, 450]]
    typed = Manifest.from_dict({"state": {}, "observed_spans": spans})
    assert typed.observed_spans == ((100, 200), (300, 450))
    assert typed.to_dict()["observed_spans"] == spans
    assert "observed_spans" not in Manifest.from_dict({"state": {}}).to_dict()
    assert part_spans(typed, ((300, 450), (0, 50))) == ((0, 50), (100, 200), (300, 450))
    for bad in ([[1]], [["1", 2]], [[1.5, 2]], {"a": 1}, [[True, 2]]):
        with pytest.raises(MapCorruptError, match="observed_spans"):
            Manifest.from_dict({"state": {}, "observed_spans": bad})


def test_recordings_round_trip_are_not_shown_and_a_damaged_value_is_a_corrupt_map() -> None:
    """``recordings`` (each build's logs and a sample of their detections,
    ``aion_cli.recording_twins``): read back as written, left out when empty and of what
    ``aion info`` shows (kilobytes of samples per build), and a value that is not a list of
    objects is a corrupt map (exit 2), not a crash."""
    from aion_cli.errors import MapCorruptError

    entry = {"logs": [{"name": "a.mcap", "sha256": "ab"}], "level": 0, "samples": ""}
    typed = Manifest.from_dict({"state": {}, "recordings": [entry]})
    assert typed.recordings == (entry,)
    assert typed.to_dict()["recordings"] == [entry]
    assert "recordings" not in typed.shown()
    assert "recordings" not in Manifest.from_dict({"state": {}}).to_dict()
    for bad in ({"a": 1}, [1], ["a"], "x"):
        with pytest.raises(MapCorruptError, match="recordings"):
            Manifest.from_dict({"state": {}, "recordings": bad})
