"""Misusing the Python API is one typed error of aion's with a hint, never a bare ``KeyError``,
``IndexError`` or ``TypeError`` from inside: wrong types, times in the wrong unit (UNIX seconds,
milliseconds, a float), unknown entries (places, rooms, buildings, cells), ends and spans of
the wrong shape. Each case below is a slip a script makes; each must say what was wrong and
how to give it (``error.hint``), as the CLI's one line and its ``hint:`` do."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.errors import InputError, UnknownNodeError
from tests.cli.conftest import Office

T = "2026-01-12 08:40"  # the office log's Monday (tests/cli/logdata.py)
SECONDS = 1768207200  # T as UNIX seconds: what time.time() and most logs' stamps are in


@pytest.fixture(scope="module")
def m(office: Office) -> aion.Map:
    return aion.Map.load(office.map)


# (what the script does, the call, a word the message must hold)
MISUSES: list[tuple[str, Callable[[aion.Map], Any], str]] = [
    ("UNIX seconds as a time", lambda m: m.predict(SECONDS), "nanoseconds"),
    ("UNIX milliseconds as a time", lambda m: m.predict(SECONDS * 1000), "nanoseconds"),
    ("a float time", lambda m: m.predict(float(SECONDS)), "float"),
    ("seconds as a series' start", lambda m: m.predict_series(SECONDS, T), "nanoseconds"),
    ("seconds as departures", lambda m: m.plan("p1", "p2", leave=(SECONDS, SECONDS)), "nano"),
    ("a list as a time", lambda m: m.predict([T]), "not a time"),
    ("None as a series' start", lambda m: m.predict_series(None, T), "not a time"),  # type: ignore[arg-type]
    ("an unknown place", lambda m: m.predict(T, nodes="p99999"), "p99999"),
    ("an unknown room", lambda m: m.predict(T, nodes="R99"), "R99"),
    ("an unknown cell", lambda m: m.predict(T, nodes="c123"), "c123"),
    ("an unknown name", lambda m: m.predict(T, nodes=["p1", "zzz"]), "zzz"),
    ("an unknown integer id", lambda m: m.predict(T, nodes=np.array([1, 2])), "not in the map"),
    ("None among nodes", lambda m: m.predict(T, nodes=[None]), "None"),  # type: ignore[list-item]
    ("an empty node list", lambda m: m.predict(T, nodes=[]), "empty"),
    ("an unknown plan end", lambda m: m.plan("p1", "nowhere", time=T), "nowhere"),
    ("an unknown room to plan to", lambda m: m.plan("R99", "p2", time=T), "R99"),
    ("a plan end past uint64", lambda m: m.plan(10**30, "p2", time=T), "2**64"),
    ("a plan end of 4 numbers", lambda m: m.plan((1, 2, 3, 4), "p2", time=T), "point"),
    ("a dict as a plan end", lambda m: m.plan({}, "p2", time=T), "point"),  # type: ignore[arg-type]
    ("an export path of one end", lambda m: m.export("x", path=("p1",)), "two items"),  # type: ignore[arg-type]
    ("an export path end of 1 number", lambda m: m.export("x", path=("p1", [1])), "point"),
    ("leave as text", lambda m: m.plan("p1", "p2", leave="08:00..09:00"), "two items"),  # type: ignore[arg-type]
    ("a series of one time", lambda m: m.export("x", series=(T,)), "two items"),  # type: ignore[arg-type]
    ("a layer list", lambda m: m.predict(T, layer=["rooms"]), "layer"),  # type: ignore[arg-type]
    ("top as a float", lambda m: m.predict(T, top=2.5), "whole number"),  # type: ignore[arg-type]
    ("a step as a list", lambda m: m.predict_series(T, "10:40", [1]), "step"),  # type: ignore[arg-type]
    ("a step in words", lambda m: m.predict_series(T, "10:40", "1 hour"), "hour"),
    ("a zone as a number", lambda m: m.predict(T, tz=3), "tz"),  # type: ignore[arg-type]
    ("an unknown zone", lambda m: m.predict(T, tz="Mars/Base"), "Mars/Base"),
    ("a path as a number", lambda m: m.export(3), "path"),  # type: ignore[arg-type]
    ("an unknown export format", lambda m: m.export("x", format="obj"), "obj"),
    # before: "unknown export format 'png'", hint "ply, pcd, mcap or dsg", though
    # aion export --format png draws one: the hint names the call that does
    ("a picture's format", lambda m: m.export("x", format="png"), "Map.picture('x'"),
    ("a keyword the call lacks", lambda m: m.predict(T, node="p1"), "nodes"),  # type: ignore[call-arg]
    ("a keyword by position", lambda m: m.predict(T, "UTC"), "positional"),  # type: ignore[misc]
    ("a map path to Map()", lambda m: aion.Map(str(m.path)), "Map.load"),  # type: ignore[arg-type]
]


@pytest.mark.parametrize("call", [c[1:] for c in MISUSES], ids=[c[0] for c in MISUSES])
def test_a_misuse_is_a_typed_error_with_a_hint(
    m: aion.Map, call: tuple[Callable[[aion.Map], Any], str]
) -> None:
    fn, word = call
    with pytest.raises(InputError) as caught:  # a KeyError, IndexError, TypeError fails here
        fn(m)
    error = caught.value
    assert word in error.message + " " + (error.hint or ""), (error.message, error.hint)
    assert error.hint, f"no hint for: {error.message}"


def test_an_unknown_entry_is_unknown_node_error_naming_it(m: aion.Map) -> None:
    """An id the map lacks is an ``UnknownNodeError`` (an ``InputError``) naming it, with ids
    it has in the hint; a ``KeyError`` of the id would be caught by ``except KeyError``, as a
    script's dict lookups are, and say nothing of the map."""
    with pytest.raises(UnknownNodeError) as caught:
        m.predict(T, nodes="p99999")
    assert "p99999" in caught.value.message
    assert not isinstance(caught.value, KeyError | IndexError)
    known = [r["id"] for r in m.predict(T).records() if r["kind"] == "node"]
    hinted = caught.value.hint or ""
    assert any(i in hinted.replace(",", " ").split() for i in known), hinted


def test_a_point_s_hint_is_given_as_the_argument_it_was_given_for(m: aion.Map) -> None:
    """The hint of a bad point said ``e.g. at=(3.5, -1.0)`` whichever argument held it: a
    plan's ``start`` or ``goal``, an export's ``path``; it shows that argument now, in its own
    form (a path is two ends), and a node id past the uint64 range had no hint at all."""
    with pytest.raises(InputError) as start:
        m.plan({}, "p2", time=T)  # type: ignore[arg-type]
    assert start.value.hint == 'e.g. start=(3.5, -1.0) or start="3.5,-1.0"'
    with pytest.raises(InputError) as goal:
        m.plan("p1", [1.0], time=T)
    assert goal.value.hint == 'e.g. goal=(3.5, -1.0) or goal="3.5,-1.0"'
    with pytest.raises(InputError) as path:
        m.export("x", path=("p1", [1]))
    assert path.value.hint == 'e.g. path=((3.5, -1.0), "p2") or path=("3.5,-1.0", "p2")'
    with pytest.raises(InputError) as at:
        m.predict(T, at="x")
    assert at.value.hint == 'e.g. at=(3.5, -1.0) or at="3.5,-1.0"'
    with pytest.raises(InputError) as huge:
        m.plan("p1", 2**64, time=T)
    assert huge.value.hint is not None
    assert "goal=(3.5, -1.0)" in huge.value.hint
    # and the hint's forms work: the point it shows is read as a point
    assert m.plan((3.5, -1.0), "p2", time=T).nodes[-1] == "p2"


def test_an_export_format_in_capitals_is_read_as_the_cli_reads_it(
    m: aion.Map, tmp_path: Any
) -> None:
    """``aion export --format PCD`` takes any case; ``Map.export(format="PCD")`` had refused it
    as an unknown format. The file written is the one ``format="pcd"`` writes."""
    lower, upper = tmp_path / "lower.pcd", tmp_path / "upper.pcd"
    m.export(lower, time=T, format="pcd")
    m.export(upper, time=T, format="PCD")
    assert upper.read_bytes() == lower.read_bytes()
    assert upper.read_bytes().startswith(b"# .PCD")
