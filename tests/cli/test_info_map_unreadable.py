"""``aion info MAP`` on a map it cannot fully read. A map whose model state a newer aion wrote
(``state_version`` above this aion's) was called *corrupted* with no hint."""

from __future__ import annotations

import json
import zipfile
from collections.abc import Callable
from pathlib import Path

from tests.cli.conftest import Office, assert_one_line_error, run


def _rewrite(src: Path, dst: Path, edit: Callable[[str, bytes], bytes]) -> Path:
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for info in zin.infolist():
            zout.writestr(info, edit(info.filename, zin.read(info)))
    return dst


def test_a_state_a_newer_aion_wrote_says_to_upgrade(office: Office, tmp_path: Path) -> None:
    def newer(name: str, data: bytes) -> bytes:
        if name != "manifest.json":
            return data
        manifest = json.loads(data)
        manifest["state"]["state_version"] += 1
        return json.dumps(manifest).encode()

    path = _rewrite(office.map, tmp_path / "newer.aion", newer)
    for args in (("info", path, "--verify"), ("predict", path, "-t", "2026-01-05 08:00")):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, "written by a newer aion")
        assert "corrupt" not in result.stderr
        assert "hint: install a newer aion" in result.stderr

