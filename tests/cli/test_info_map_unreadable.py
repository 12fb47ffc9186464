"""``aion info MAP`` on a map it cannot fully read. A map whose model state a newer aion wrote
(``state_version`` above this aion's) was called *corrupted* with no hint; a map whose scene
graph member is damaged was shown without its rooms, buildings and graph layer, exit 0 and not
a word on why, as if the graph held none."""

from __future__ import annotations

import json
import zipfile
from collections.abc import Callable
from pathlib import Path

from tests.cli.conftest import Office, assert_one_line_error, run, run_json


def _rewrite(src: Path, dst: Path, edit: Callable[[str, bytes], bytes]) -> Path:
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for info in zin.infolist():
            zout.writestr(info, edit(info.filename, zin.read(info)))
    return dst


def newer_state(name: str, data: bytes) -> bytes:
    """A map member as a newer aion would write it: the manifest's state version one up."""
    if name != "manifest.json":
        return data
    manifest = json.loads(data)
    manifest["state"]["state_version"] += 1
    return json.dumps(manifest).encode()


def test_a_state_a_newer_aion_wrote_says_to_upgrade(office: Office, tmp_path: Path) -> None:
    path = _rewrite(office.map, tmp_path / "newer.aion", newer_state)
    for args in (("info", path, "--verify"), ("predict", path, "-t", "2026-01-05 08:00")):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, "written by a newer aion")
        assert "corrupt" not in result.stderr
        assert "hint: install a newer aion" in result.stderr


def test_a_damaged_graph_member_is_a_warning_not_a_map_without_rooms(
    office: Office, tmp_path: Path
) -> None:
    doc = run_json("info", office.map, "--format", "json")
    assert doc["nav_layer"] == "places"  # the office log's graph: its places are read
    assert doc["warnings"] == []

    def damage(name: str, data: bytes) -> bytes:
        if name != "graph_places_ids.npy":
            return data
        return data[:-1] + bytes([data[-1] ^ 0xFF])

    path = _rewrite(office.map, tmp_path / "damaged.aion", damage)
    assert run("predict", path, "-t", "2026-01-05 08:00").exit_code == 2  # queries refuse it
    doc = run_json("info", path, "--format", "json")
    assert doc["nav_layer"] is None
    assert len(doc["warnings"]) == 1
    assert "graph_places_ids" in doc["warnings"][0]
    table = run("info", path)
    assert table.exit_code == 0
    lines = [line for line in table.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, table.stderr
    assert lines[0].startswith("warning: "), table.stderr
    assert "graph_places_ids fails its crc32 checksum" in lines[0]
    assert "--verify" in lines[0]
