"""Which logs of a build are distinct, and their hashes: logs whose sizes collide are hashed
before the build (a copy is used once, a log already in the map refused), the others by a
thread beside it, with the same entries in the same order."""

from __future__ import annotations

import hashlib
import threading
from pathlib import Path
from typing import Any

import pytest

from aion_cli.build_report import NoProgress
from aion_cli.errors import InputError
from aion_cli.provenance import distinct_logs, provenance


class Phases:
    """A progress sink that records its phases and the units advanced."""

    def __init__(self) -> None:
        self.phases: list[tuple[str, int]] = []
        self.advanced = 0

    def start(self, description: str, total: int, unit: str = "msgs") -> None:
        self.phases.append((description, total))

    def advance(self, n: int) -> None:
        self.advanced += n


def _file(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_only_colliding_sizes_are_hashed_before_and_the_entries_are_all_there(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    a = _file(tmp_path / "a.mcap", b"a" * 1000)
    copy = _file(tmp_path / "copy.mcap", b"a" * 1000)  # byte-identical to a
    twin = _file(tmp_path / "twin.mcap", b"b" * 1000)  # a's size, other bytes
    alone = _file(tmp_path / "alone.mcap", b"c" * 3000)
    hashed: list[str] = []

    def counting(path: Path, *args: Any) -> dict[str, Any]:
        hashed.append(path.name)
        return provenance(path, *args)

    monkeypatch.setattr("aion_cli.provenance.provenance", counting)
    logs = distinct_logs((a, alone, copy, twin), NoProgress(), {})
    assert logs.logs == (a, alone, twin)
    assert logs.notes == [f"{copy} is the same log as {a} (same sha256): it is used once"]
    assert hashed == ["a.mcap", "copy.mcap", "twin.mcap"]  # not the log of its own size
    entries = logs.start().entries(NoProgress())
    assert hashed[-1] == "alone.mcap"
    assert [(e["name"], e["size"], e["sha256"]) for e in entries] == [
        (p.name, p.stat().st_size, _sha(p)) for p in (a, alone, twin)
    ]


def test_a_log_of_a_map_input_size_is_checked_before_the_build(tmp_path: Path) -> None:
    log = _file(tmp_path / "a.mcap", b"x" * 500)
    other = _file(tmp_path / "b.mcap", b"y" * 500)
    with pytest.raises(InputError, match=r"a\.mcap is already in the map"):
        distinct_logs((log,), NoProgress(), {_sha(log): 500})
    # the same size, other bytes: hashed at once (the size collides), and not refused
    logs = distinct_logs((other,), NoProgress(), {_sha(log): 500})
    assert logs.entries(NoProgress())[0]["sha256"] == _sha(other)


def test_logs_the_map_holds_are_all_named_and_the_new_ones_given(tmp_path: Path) -> None:
    """``aion build day*.mcap --map week.aion``, the glob catching the days the map holds:
    the error named only the first of them ("mon.mcap is already in the map"), so a user
    found the others, and the new day, by trial. It names every one the map holds and the
    logs to give instead."""
    mon = _file(tmp_path / "mon.mcap", b"m" * 300)
    tue = _file(tmp_path / "tue.mcap", b"t" * 400)
    wed = _file(tmp_path / "wed.mcap", b"w" * 500)
    known = {_sha(mon): 300, _sha(wed): 500}
    with pytest.raises(InputError) as refused:
        distinct_logs((mon, tue, wed), NoProgress(), known)
    assert refused.value.message == "mon.mcap, wed.mcap are already in the map (same sha256)"
    assert refused.value.hint == (
        "each log may be added to a map only once: give only the new ones (tue.mcap)"
    )
    with pytest.raises(InputError) as alone:  # nothing new: nothing to give instead
        distinct_logs((wed,), NoProgress(), known)
    assert alone.value.message == "wed.mcap is already in the map (same sha256)"
    assert alone.value.hint == "each log may be added to a map only once"

def test_a_background_hash_shows_progress_when_waited_for(tmp_path: Path) -> None:
    big = _file(tmp_path / "big.mcap", b"z" * (3 << 20))
    logs = distinct_logs((big,), NoProgress(), {})
    sink = Phases()
    entries = logs.entries(sink)  # never started: hashed here, no phase needed
    assert entries[0]["sha256"] == _sha(big)
    started = distinct_logs((big,), NoProgress(), {}).start()
    assert started.entries(sink)[0]["sha256"] == _sha(big)
    assert all(total == 3 for _, total in sink.phases)  # MiB, if the wait showed a bar


def test_a_failed_build_stops_its_background_hash(tmp_path: Path) -> None:
    big = _file(tmp_path / "big.mcap", b"z" * (64 << 20))
    logs = distinct_logs((big,), NoProgress(), {})
    logs.cancel()  # before the first block: the thread ends at once
    logs.start()
    for thread in threading.enumerate():
        if thread.name == "aion-hash-logs":
            thread.join(5.0)
            assert not thread.is_alive()


def test_a_background_hash_error_reaches_the_build(tmp_path: Path) -> None:
    log = _file(tmp_path / "gone.mcap", b"q" * 100)
    logs = distinct_logs((log,), NoProgress(), {})
    log.unlink()  # removed during the build
    with pytest.raises(InputError, match=r"gone\.mcap is not a regular file"):
        logs.start().entries(NoProgress())


def test_a_log_given_twice_is_named_so(tmp_path: Path) -> None:
    """``aion build run.mcap run.mcap``: the note said "run.mcap is the same log as run.mcap
    (same sha256)", as of a copy; the same file under two spellings is given twice."""
    a = _file(tmp_path / "a.mcap", b"a" * 1000)
    link = tmp_path / "link.mcap"
    link.symlink_to(a)
    copy = _file(tmp_path / "copy.mcap", b"a" * 1000)
    logs = distinct_logs((a, a, link, copy), NoProgress(), {})
    assert logs.logs == (a,)
    assert logs.notes == [
        f"{a} is given twice: it is used once",
        f"{link} is {a} given again: it is used once",
        f"{copy} is the same log as {a} (same sha256): it is used once",
    ]
