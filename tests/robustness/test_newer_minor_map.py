"""A map of a newer minor format (2.7 here; this aion writes 2.1) is read by queries, which
ignore what they do not know, but refused by ``build --map`` and ``merge``: they would write it
back as 2.1 and drop whatever the newer aion stored, without a word."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tests.robustness.conftest import Office, fails, rewrite_map, run


def _newer_minor(office: Office, folder: Path) -> Path:
    def edit(manifest: dict[str, Any]) -> None:
        manifest["version"] = "2.7"
        manifest["stored_by_a_newer_aion"] = True

    return rewrite_map(office.map, folder / "newer_minor.aion", manifest_edit=edit)


def test_queries_read_a_newer_minor_map(office: Office, tmp_path: Path) -> None:
    newer = _newer_minor(office, tmp_path)
    result = run("predict", newer, "--time", "2026-01-06T09:00", "--format", "json", "-q")
    assert result.exit_code == 0, result.stderr
    assert result.stdout.strip().startswith(("{", "["))


def test_continuing_a_newer_minor_map_is_refused(office: Office, tmp_path: Path) -> None:
    newer = _newer_minor(office, tmp_path)
    out = tmp_path / "continued.aion"
    result = run("build", office.log, "--map", newer, "-o", out)
    fails(result, "2.7", "newer than this aion writes")
    assert "upgrade aion" in result.stderr
    assert not out.exists()


def test_merging_a_newer_minor_map_is_refused_naming_it(office: Office, tmp_path: Path) -> None:
    newer = _newer_minor(office, tmp_path)
    out = tmp_path / "merged.aion"
    result = run("merge", office.map, newer, "-o", out)
    fails(result, str(newer), "newer than this aion writes")
    assert not out.exists()
