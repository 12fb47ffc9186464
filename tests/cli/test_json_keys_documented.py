"""Every key of a command's real JSON output (and every column of predict's CSV) is named in
its --help (which README points to): predict (a time, --historical, a series), plan (with a
room, a point and --leave), info (a log, a fixed sensor's log, a log without a detection topic,
a map, a part, a query-only and a merged map, a scene-graph file), build, merge and compact."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from tests.cli.conftest import SAMPLE, run, run_json
from tests.shared_data import SHARED_DATA

AT = ("--time", "2026-01-12 08:40", "--tz", "UTC")

DATA_KEYED = {
    # objects whose keys are data (topics, reasons, roles, families, parameters), not fields
    "detection_decoding", "detections_by_topic", "dropped", "log_times_dropped",
    "dsg_versions", "frames_without_tf", "tf_roots", "roles", "config", "skipped", "aion",
    "declared_zones",
}
DATA_KEYED_IN = {"families": {"flow", "direction"}}
"""Such objects inside one object only: a map's ``families.flow`` is keyed by family names
(its other keys, and those of ``counts``, are fields)."""


def keys(doc: Any, parent: str = "") -> set[str]:
    """The field names of a JSON document, nested objects and lists of objects included,
    without descending into objects keyed by data."""
    out: set[str] = set()
    if isinstance(doc, list):
        for item in doc:
            out |= keys(item, parent)
    elif isinstance(doc, dict):
        for key, value in doc.items():
            out.add(key)
            if key not in DATA_KEYED and key not in DATA_KEYED_IN.get(parent, ()):
                out |= keys(value, key)
    return out


def help_text(command: str) -> str:
    result = run(command, "--help")
    assert result.exit_code == 0, result.stderr
    return " ".join(result.stdout.split())


def assert_documented(command: str, *docs: Any) -> None:
    text = help_text(command)
    found = {k for doc in docs for k in keys(doc)}
    undocumented = sorted(k for k in found if not re.search(rf"\b{k}\b", text))
    assert not undocumented, f"aion {command} --help does not name {undocumented}"


@pytest.fixture(scope="module")
def maps(sample_map: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("json-keys")
    out = {"full": sample_map}
    for name, args in {
        "part": ("build", SAMPLE, "--part", "-o"),
        "compact": ("compact", sample_map, "-o"),
    }.items():
        out[name] = folder / f"{name}.aion"
        result = run(*args, out[name], "-q")
        assert result.exit_code == 0, result.stderr
    out["merged"] = folder / "merged.aion"
    merged = run_json("merge", out["part"], "-o", out["merged"], "--format", "json")
    out["merge_report"] = merged  # type: ignore[assignment]
    return out


def test_predict_keys_are_in_its_help(sample_map: Path) -> None:
    assert_documented(
        "predict",
        run_json("predict", sample_map, *AT, "--format", "json"),
        run_json("predict", sample_map, "--historical", "--format", "json"),
        run_json(
            "predict", sample_map, "--layer", "rooms", "--from", "2026-01-12 06:00", "--to",
            "2026-01-12 08:00", "--step", "1h", "--tz", "UTC", "--format", "json",
        ),
    )


def test_predict_csv_columns_are_in_its_help(sample_map: Path) -> None:
    text = help_text("predict")
    series = ("--from", "2026-01-12 06:00", "--to", "2026-01-12 08:00", "--step", "1h")
    for args in (AT, ("--historical",), (*series, "--tz", "UTC")):
        result = run("predict", sample_map, *args, "--format", "csv")
        assert result.exit_code == 0, result.stderr
        header = result.stdout.splitlines()[0].split(",")
        columns = {re.sub(r"^histogram_\d+$", "histogram_0", c) for c in header}
        undocumented = sorted(c for c in columns if not re.search(rf"\b{c}\b", text))
        assert not undocumented, f"aion predict --help does not name the columns {undocumented}"


def test_plan_keys_are_in_its_help(sample_map: Path) -> None:
    leave = ("--leave", "2026-01-12 08:00..2026-01-12 08:30", "--tz", "UTC")
    assert_documented(
        "plan",
        run_json("plan", sample_map, "--from", "p103", "--to", "p2", *AT, "--format", "json"),
        run_json("plan", sample_map, "--from", "kitchen", "--to", "0,0", *leave, "--format",
                 "json"),
    )


def test_info_keys_are_in_its_help(maps: dict[str, Path], tmp_path: Path) -> None:
    fixed = tmp_path / "fixed.mcap"
    assert run("simulate", "-o", fixed, "--robot", "fixed", "--days", "0.05", "-q").exit_code == 0
    docs = [
        run_json("info", SAMPLE, "--format", "json"),
        run_json("info", fixed, "--format", "json"),
        *(run_json("info", maps[k], "--format", "json") for k in ("full", "part", "compact")),
        run_json("info", maps["merged"], "--verify", "--format", "json"),
    ]
    for doc, key in zip(docs[1:], ("fixed_sensor", "rooms", "part", "query_only", "merged_from"),
                        strict=True):
        assert key in doc
    assert "verified" in docs[5]
    seen = tmp_path / "seen.mcap"  # office hours: people to build a fixed sensor's map of
    assert run("simulate", "-o", seen, "--robot", "fixed", "--days", "0.05", "--start",
               "2026-01-05T09:00", "-q").exit_code == 0  # fmt: skip
    fixed_map = tmp_path / "fixed.aion"  # counts{recording_windows, recording_reach, ...}
    assert run("build", seen, "-o", fixed_map, "--workers", "1", "-q").exit_code == 0
    docs.append(run_json("info", fixed_map, "--format", "json"))
    assert {"recording_reach", "recording_first"} <= set(docs[-1]["counts"])
    assert {"calendar", "observed_bins"} <= set(docs[-1]["families"])
    bag = SHARED_DATA / "logs" / "rosbagjs_fixtures" / "example.bag"
    if bag.exists():  # no detection topic: mapping_example
        docs.append(run_json("info", bag, "--format", "json"))
    graph = SHARED_DATA / "dsg" / "apartment_dsg.json"
    if graph.exists():
        docs.append(run_json("info", graph, "--format", "json"))
    assert_documented("info", *docs)


def test_build_merge_compact_keys_are_in_their_help(
    maps: dict[str, Path], tmp_path: Path
) -> None:
    built = run_json("build", SAMPLE, "-o", tmp_path / "b.aion", "--format", "json")
    assert_documented("build", built)
    assert_documented("merge", maps["merge_report"])
    compacted = run_json("compact", maps["full"], "-o", tmp_path / "c.aion", "--format", "json")
    assert_documented("compact", compacted)
