"""A map pickled for another process (multiprocessing, Dask): one loaded from a file crosses
as that file and is read again there. Before, the pickle carried the number of the file
descriptor the map held open, and every query in the other process failed: ``OSError: Bad file
descriptor``, or ``MapFileError: ... overwritten in place`` where that number named another
file there."""

from __future__ import annotations

import json
import os
import pickle
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import aion_cli as aion
from aion_cli.errors import MapFileError
from tests.cli.conftest import run_json

T = "2026-01-12 08:40"
READ_BACK = """
import json, pickle, sys
m = pickle.loads(open(sys.argv[1], "rb").read())
print(json.dumps(m.predict("2026-01-12 08:40", tz="UTC", top=5).to_dict()))
"""


def test_a_pickled_map_answers_in_another_process(
    sample_map: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    shutil.copy(sample_map, tmp_path / "office.aion")
    monkeypatch.chdir(tmp_path)
    m = aion.Map.load("office.aion")  # a relative path, read again from another folder
    m.predict(T, tz="UTC")  # members read through the open file before pickling
    (tmp_path / "m.pkl").write_bytes(pickle.dumps(m))
    other = tmp_path / "elsewhere"  # a process in another folder
    other.mkdir()
    done = subprocess.run(
        [sys.executable, "-c", READ_BACK, str(tmp_path / "m.pkl")],
        capture_output=True,
        text=True,
        cwd=other,
        check=False,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr  # before: MapFileError, overwritten in place
    cli = run_json("predict", m.path, "--time", T, "--tz", "UTC", "--top", "5", "--format", "json")
    assert len(cli["entries"]) == 5
    assert json.loads(done.stdout) == cli


def test_a_pickled_map_whose_file_changed_is_refused(sample_map: Path, tmp_path: Path) -> None:
    path = tmp_path / "office.aion"
    shutil.copy(sample_map, path)
    data = pickle.dumps(aion.Map.load(path))
    os.utime(path, ns=(0, 0))  # as if rewritten: the bytes read there may not be these
    with pytest.raises(MapFileError, match="changed since the map was pickled"):
        pickle.loads(data)


def test_a_map_whose_file_is_gone_is_not_pickled(sample_map: Path, tmp_path: Path) -> None:
    path = tmp_path / "office.aion"
    shutil.copy(sample_map, path)
    m = aion.Map.load(path)
    path.unlink()
    assert len(m.predict(T, tz="UTC")) > 0  # the map itself still answers
    with pytest.raises(MapFileError, match="replaced or deleted since the map was loaded"):
        pickle.dumps(m)


def test_an_in_memory_map_pickles_whole(tmp_path: Path) -> None:
    from tests.cli.test_api_from_state import _fed

    m = aion.Map.from_state(_fed().state, timezone="UTC")
    copy = pickle.loads(pickle.dumps(m))  # its lock left out, a new one made
    at = "2026-01-05 10:30"
    assert copy.predict(at).to_dict() == m.predict(at).to_dict()
    saved = copy.save(tmp_path / "mem.aion")
    assert aion.Map.load(saved).predict(at).records() == m.predict(at).records()


def test_a_map_loaded_by_a_relative_path_pickles_from_another_folder(
    sample_map: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A notebook that loads ``office.aion`` and then changes folder (``os.chdir``) can still
    pickle the map (before: "replaced or deleted since the map was loaded": the relative
    path was looked up in the new folder)."""
    shutil.copy(sample_map, tmp_path / "office.aion")
    monkeypatch.chdir(tmp_path)
    m = aion.Map.load("office.aion")
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    copy = pickle.loads(pickle.dumps(m))
    assert copy.predict(T, tz="UTC").records() == m.predict(T, tz="UTC").records()


def test_a_pickled_map_is_read_again_as_map_load_reads_it(
    sample_map: Path, tmp_path: Path
) -> None:
    """The other process reads the map as :meth:`aion.Map.load` does, without the per-entry
    Fourier sums only learning reads (most of a full map's bytes). Before, it read the map
    whole: the sums (``cnt_fourier`` entries x flows x periods) were in memory and the
    forecast components were computed again from them, on every worker of a pool."""
    path = tmp_path / "office.aion"
    shutil.copy(sample_map, path)
    m = aion.Map.load(path)
    copy = pickle.loads(pickle.dumps(m))
    assert m.state.components is not None  # what Map.load reads: the forecast components
    assert m.state.temporal.cnt_fourier.size == 0  # ... and not the sums
    assert copy.state.components is not None
    assert copy.state.temporal.cnt_fourier.shape == m.state.temporal.cnt_fourier.shape
    assert copy.predict(T, tz="UTC").records() == m.predict(T, tz="UTC").records()
