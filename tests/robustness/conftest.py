"""Helpers of the robustness tests: small hand-made logs, map surgery and CLI runners.

Logs are written with ``formats.writers.LogWriter`` from plain message dicts, so every fault is
placed exactly where a test wants it (a NaN in message 101, a stamp three days ahead...). The
office log and its map (``tests/cli/logdata.py``) are built once per session.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner, Result

from aion_cli.cli.main import cli
from tests.cli.logdata import T0, S, build_graph, write_office_log

AION = Path(sys.executable).with_name("aion")
TRACKED = "spencer_tracking_msgs/msg/TrackedPersons"
TF = "tf2_msgs/msg/TFMessage"
DSG = "hydra_msgs/msg/DsgUpdate"
DSG_TOPIC = "/hydra/backend/dsg"

Message = tuple[str, str, dict[str, Any], int]
"""(topic, type, message dict, log time ns) as LogWriter.write takes them."""


def stamp(t_ns: int) -> dict[str, int]:
    return {"sec": t_ns // S, "nanosec": t_ns % S}


def person(
    t_ns: int,
    xyz: tuple[float, float, float],
    track: int = 1,
    frame: str = "map",
    header_ns: int | None = None,
) -> Message:
    """One TrackedPersons message on /tracks at log time ``t_ns`` with one person walking +x;
    its header stamp is ``header_ns`` (default: ``t_ns``)."""
    x, y, z = xyz
    msg = {
        "header": {"stamp": stamp(t_ns if header_ns is None else header_ns), "frame_id": frame},
        "tracks": [
            {
                "track_id": track,
                "is_matched": True,
                "pose": {"pose": {"position": {"x": x, "y": y, "z": z}, "orientation": {"w": 1.0}}},
                "twist": {"twist": {"linear": {"x": 1.0, "y": 0.0, "z": 0.0}}},
            }
        ],
    }
    return ("/tracks", TRACKED, msg, t_ns)


def walk(
    n: int, start_s: int = 0, xyz: tuple[float, float, float] = (2.1, 0.1, 0.0)
) -> list[Message]:
    """``n`` person messages one second apart from ``T0 + start_s``."""
    return [person(T0 + (start_s + k) * S, xyz) for k in range(n)]


def robot_tf(t_ns: int, child: str = "base_link") -> Message:
    """map -> ``child`` at (1, 0, 0), identity rotation."""
    msg = {
        "transforms": [
            {
                "header": {"stamp": stamp(t_ns), "frame_id": "map"},
                "child_frame_id": child,
                "transform": {
                    "translation": {"x": 1.0, "y": 0.0, "z": 0.0},
                    "rotation": {"w": 1.0},
                },
            }
        ]
    }
    return ("/tf", TF, msg, t_ns)


def graph_payload() -> np.ndarray:
    """The office scene graph (tests/cli/logdata.py) as a DsgUpdate payload."""
    return np.frombuffer(build_graph().to_binary(False), dtype=np.uint8)


def scene_graph(t_ns: int, payload: np.ndarray | bytes) -> Message:
    data = np.frombuffer(payload, dtype=np.uint8) if isinstance(payload, bytes) else payload
    msg = {
        "header": {"stamp": stamp(t_ns), "frame_id": "map"},
        "layer_contents": data,
        "full_update": True,
    }
    return (DSG_TOPIC, DSG, msg, t_ns)


def write_log(path: Path, messages: Iterable[Message], container: str = "mcap") -> Path:
    """Write ``messages`` (any order: containers keep what they are given) to ``path``."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path, container) as writer:
        for topic, msgtype, msg, t_ns in messages:
            writer.write(topic, msgtype, msg, t_ns)
    return path


# -- running the CLI -------------------------------------------------------------------------


def run(*args: str | Path) -> Result:
    """The CLI in-process (click's runner, stdout and stderr apart)."""
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def build_json(*args: str | Path) -> dict[str, Any]:
    """``aion build ARGS --format json`` in-process; asserts success, returns the report."""
    result = run("build", *args, "--format", "json")
    assert result.exit_code == 0, result.stderr
    report: dict[str, Any] = json.loads(result.stdout)
    return report


def aion_env() -> dict[str, str]:
    return {**os.environ, "TZ": "UTC", "COLUMNS": "200", "AION_DEBUG": ""}


def run_process(*args: str | Path, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """The installed ``aion`` console script in a subprocess."""
    return subprocess.run(
        [str(AION), *map(str, args)],
        capture_output=True,
        text=True,
        env=aion_env(),
        timeout=timeout,
        check=False,
    )


def assert_one_error(stderr: str, *fragments: str) -> None:
    """Exactly one ``error:`` line, optionally a ``hint:`` line, nothing else, no traceback."""
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert "Traceback" not in stderr, stderr
    assert [line for line in lines if line.startswith("error: ")] == lines[:1], stderr
    assert len(lines) in (1, 2), stderr
    if len(lines) == 2:
        assert lines[1].startswith("hint: "), stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, stderr)



def fails(result: Any, *fragments: str) -> None:
    """A CLI result that is an input error (exit 2) with exactly one ``error:`` line naming
    ``fragments`` (:func:`assert_one_error`)."""
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, *fragments)

# -- map surgery -----------------------------------------------------------------------------


def rewrite_map(
    src: Path,
    dst: Path,
    members: dict[str, bytes] | None = None,
    manifest_edit: Callable[[dict[str, Any]], None] | None = None,
) -> Path:
    """Copy the zip ``src`` to ``dst`` replacing member bytes and/or editing the manifest."""
    with zipfile.ZipFile(src) as zin:
        contents = {name: zin.read(name) for name in zin.namelist()}
    contents.update(members or {})
    if manifest_edit is not None:
        manifest = json.loads(contents["manifest.json"])
        manifest_edit(manifest)
        contents["manifest.json"] = json.dumps(manifest).encode()
    with zipfile.ZipFile(dst, "w", compression=zipfile.ZIP_STORED) as zout:
        for name, data in contents.items():
            zout.writestr(name, data)
    return dst


def map_arrays(path: Path) -> dict[str, np.ndarray]:
    """Every array of a map, checksums verified."""
    from aion_cli.formats.mapfile import read_map

    return read_map(path)[0]


def assert_same_arrays(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    """Same members, dtypes and shapes; integer, boolean and string arrays exactly equal,
    floating-point ones to rounding (1e-12 relative): FreMEn absorbs windows in batches, and
    where a build stops decides how sums are grouped."""
    assert sorted(a) == sorted(b)
    for name in a:
        assert a[name].dtype == b[name].dtype, name
        assert a[name].shape == b[name].shape, name
        if a[name].dtype.kind in "fc":
            np.testing.assert_allclose(a[name], b[name], rtol=1e-12, atol=1e-12, err_msg=name)
        else:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name)


# -- session artefacts -----------------------------------------------------------------------


@dataclass(frozen=True)
class Office:
    """The office log (tests/cli/logdata.py) and a map built from it."""

    log: Path
    map: Path

    def copy_map(self, dst: Path) -> Path:
        shutil.copyfile(self.map, dst)
        return dst


@pytest.fixture(scope="session")
def office(tmp_path_factory: pytest.TempPathFactory) -> Office:
    folder = tmp_path_factory.mktemp("robust_office")
    log = folder / "office.mcap"
    write_office_log(log)
    out = folder / "office.aion"
    build_json(log, "-o", out)
    return Office(log, out)
