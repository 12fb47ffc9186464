"""``aion.Map.load`` reads a map's manifest at once and its state on first use: what the map
says of itself (``Map.manifest``, ``Map.timezone``, as ``aion info MAP`` shows it) reads no
member of the state. Before, ``Map.load`` read and checksummed every member a query reads
(78 of the sample map, most of its bytes) to answer ``m.timezone``, where ``aion info`` reads
13. The state read later is the file's that was loaded, as when it was read at once."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

import aion_cli as aion
from aion_cli.errors import MapFileError
from aion_cli.formats import mapfile_read
from tests.cli.conftest import SAMPLE, Office, run

T = "2026-01-12 08:40"


@pytest.fixture
def reads(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The names of the map members read (and checksummed) from now on."""
    names: list[str] = []
    real = mapfile_read.MapMembers._read

    def counted(self: mapfile_read.MapMembers, name: str, rec: dict[str, object]) -> object:
        names.append(name)
        return real(self, name, rec)

    monkeypatch.setattr(mapfile_read.MapMembers, "_read", counted)
    return names


def test_what_a_map_says_of_itself_reads_none_of_its_state(
    sample_map: Path, reads: list[str]
) -> None:
    m = aion.Map.load(sample_map)
    assert m.timezone == "UTC"
    assert m.manifest.counts["used"] > 0
    assert m.path == sample_map
    config = m.config  # the model parameters, as aion info shows them
    assert reads == []  # before: every member a query reads
    run("predict", sample_map, "--time", T, "--tz", "UTC", "-q")
    the_cli_reads = sorted(set(reads))
    reads.clear()
    assert len(m.predict(T, tz="UTC")) > 0
    assert sorted(set(reads)) == the_cli_reads  # a query reads what aion predict reads
    assert m.config == config == m.state.config
    reads.clear()
    m.plan("p103", "p2", time=T, tz="UTC")
    assert reads == []  # once


def test_a_maps_repr_reads_none_of_its_state(sample_map: Path, reads: list[str]) -> None:
    """``repr(m)`` (a notebook showing the map) counts its entries from the manifest: it read
    every member a query reads to count the state's live rows. The count is the state's."""
    m = aion.Map.load(sample_map)
    text = repr(m)
    assert reads == []  # before: the whole state
    assert m._source.loaded is None
    live = len(m.state.entries.live_rows())  # the state read, as a query reads it
    assert live > 100
    assert text == f"<aion.Map {sample_map}: {live:,} entries>"
    assert repr(m) == text  # the same once the state is read


def test_a_map_replaced_or_deleted_before_its_first_query_answers_as_loaded(
    sample_map: Path, office: Office, tmp_path: Path
) -> None:
    """The state is read from the file loaded (held open), not from whatever its path names
    by the first query: aion's writers replace a map atomically, which a loaded map
    survives."""
    live = tmp_path / "live.aion"
    shutil.copy(sample_map, live)
    expected = aion.Map.load(sample_map).predict(T, tz="UTC").records()
    m = aion.Map.load(live)
    os.replace(shutil.copy(office.map, tmp_path / "other.aion"), live)  # another map
    assert aion.Map.load(live).predict(T, tz="UTC").records() != expected
    assert m.predict(T, tz="UTC").records() == expected
    gone = tmp_path / "gone.aion"
    shutil.copy(sample_map, gone)
    held = aion.Map.load(gone)
    gone.unlink()
    assert held.predict(T, tz="UTC").records() == expected
    overwritten = tmp_path / "overwritten.aion"
    shutil.copy(sample_map, overwritten)
    victim = aion.Map.load(overwritten)
    shutil.copyfile(office.map, overwritten)  # in place: never read
    with pytest.raises(MapFileError, match="overwritten in place"):
        victim.predict(T, tz="UTC")


def test_a_map_aion_cannot_read_is_refused_when_loaded(office: Office, tmp_path: Path) -> None:
    """Reading the state later does not defer what says a map is unreadable: a model state
    a newer aion wrote is refused by ``Map.load`` itself, as when it read the state at once."""

    from aion_cli.errors import MapVersionError
    from tests.cli.test_info_map_unreadable import _rewrite, newer_state

    path = _rewrite(office.map, tmp_path / "newer.aion", newer_state)
    with pytest.raises(MapVersionError, match="written by a newer aion"):
        aion.Map.load(path)


def test_a_maps_repr_says_what_it_cannot_do(
    sample_map: Path, tmp_path: Path, reads: list[str]
) -> None:
    """A part map answers no query and a query-only map is neither continued nor merged; their
    repr read like an ordinary map's, so a notebook showed nothing amiss until a query (or a
    continued build) failed. It says so now, from the manifest alone."""
    compacted = aion.compact(sample_map, tmp_path / "robot.aion")
    part = aion.build([SAMPLE], output=tmp_path / "mon.part.aion", part=True)
    reads.clear()
    entries = f"{len(aion.Map.load(sample_map).state.entries.live_rows()):,} entries"
    reads.clear()
    for m in (compacted, aion.Map.load(compacted.path)):
        assert repr(m) == (
            f"<aion.Map {compacted.path}: {entries}, query-only (aion.compact: not continued "
            "or merged)>"
        )
    for m in (part, aion.Map.load(part.path)):
        assert repr(m).startswith(f"<aion.Map {part.path}: ")
        assert repr(m).endswith(" entries, a part map (answers no query: aion.merge it)>")
    assert reads == []
    assert repr(aion.Map.load(sample_map)) == f"<aion.Map {sample_map}: {entries}>"
