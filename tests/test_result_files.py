"""A shard's result handed from a worker to the parent through a file
(aion_cli.result_files): what goes where, what comes back, and what is left behind."""

from __future__ import annotations

import queue
from pathlib import Path

import numpy as np
import pytest

from aion_cli.result_files import MIN_FILE_BYTES, receive, result_folder, send


def _result() -> dict[str, object]:
    rng = np.random.default_rng(3)
    return {
        "counts": rng.random((700, 9, 31)) + 1j * rng.random((700, 9, 31)),  # ~3 MB
        "rows": np.arange(700, dtype=np.int64),
        "strided": rng.random((50, 40))[:, ::2],  # not contiguous: pickled in band
        "name": "shard",
    }


def test_large_arrays_come_back_through_a_file_that_is_then_removed() -> None:
    out: queue.Queue[tuple[object, ...]] = queue.Queue()
    sent = _result()
    with result_folder() as folder:
        send(out, 4, sent, folder)
        item = out.get_nowait()
        assert item[0] == "result-file"
        assert item[1] == 4
        assert len(list(folder.iterdir())) == 1
        back = receive(item)
        assert list(folder.iterdir()) == []
    assert not folder.exists()
    assert back.keys() == sent.keys()
    for key, value in sent.items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(back[key], value)
            assert back[key].dtype == value.dtype
            assert back[key].flags.writeable  # the parent's map state is written to
        else:
            assert back[key] == value


def test_small_results_and_a_missing_folder_go_through_the_queue(tmp_path: Path) -> None:
    out: queue.Queue[tuple[object, ...]] = queue.Queue()
    small = {"rows": np.arange(10)}
    assert small["rows"].nbytes < MIN_FILE_BYTES
    send(out, 0, small, tmp_path)
    kind, index, whole = out.get_nowait()
    assert (kind, index) == ("result", 0)
    assert whole is small
    big = _result()
    send(out, 1, big, tmp_path / "gone")  # cannot be written: no folder
    kind, index, whole = out.get_nowait()
    assert (kind, index) == ("result", 1)
    assert whole is big
    assert not (tmp_path / "gone").exists()


def _interrupted(made: list[Path]) -> None:
    with result_folder() as folder:
        made.append(folder)
        (folder / "shard-0-1.bin").write_bytes(b"x" * 100)  # a worker's file, not yet read
        raise KeyboardInterrupt


def test_the_folder_is_removed_however_the_build_ends() -> None:
    made: list[Path] = []
    with pytest.raises(KeyboardInterrupt):
        _interrupted(made)
    assert len(made) == 1
    assert not made[0].exists()
