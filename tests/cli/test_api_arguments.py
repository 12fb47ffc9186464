"""The Python API at its boundary: wrong types and values are one typed ``InputError`` naming
the argument (never a ``TypeError`` or ``AttributeError`` from inside), plausible slips are
read as meant, nothing is silently ignored, and a loaded map is saved as it was loaded."""

from __future__ import annotations

import inspect
import os
import re
import shutil
import sys
import types
import typing
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.errors import InputError, MapFileError
from tests.cli.conftest import Office

T = "2026-01-12 08:40"  # the office log's Monday (tests/cli/logdata.py)


@pytest.fixture(scope="module")
def m(office: Office) -> aion.Map:
    return aion.Map.load(office.map)


def _ids(table: aion.Table) -> list[str]:
    return [r["id"] for r in table.records()]


def test_one_node_id_alone_is_one_node(m: aion.Map) -> None:
    assert _ids(m.predict(T, tz="UTC", nodes="p4")) == ["p4"]
    assert _ids(m.predict(T, tz="UTC", nodes=["p4"])) == ["p4"]
    series = m.predict_series(T, "2026-01-12 09:40", "30m", tz="UTC", nodes="p4")
    assert [r["id"] for r in series.records()] == ["p4"]


def test_zones_as_names_zoneinfo_and_timezone_objects(m: aion.Map) -> None:
    expected = m.predict(T, tz="UTC").records()
    for tz in (ZoneInfo("UTC"), UTC, timezone(timedelta(0))):
        assert m.predict(T, tz=tz).records() == expected
    london = m.predict(T, tz=ZoneInfo("Europe/London"))
    assert london.zone == "Europe/London"
    plus_two = m.predict("2026-01-12 10:40", tz=timezone(timedelta(hours=2)))
    assert plus_two.time_ns == m.predict(T, tz="UTC").time_ns
    with pytest.raises(InputError, match="tz must be a zone name"):
        m.predict(T, tz=5)  # type: ignore[arg-type]


def _declared(fn: Any, name: str) -> Any:
    """The type of ``fn``'s parameter ``name``, its annotation evaluated where ``fn`` is
    defined (the API's modules use ``from __future__ import annotations``)."""
    text = inspect.signature(fn).parameters[name].annotation
    return eval(text, vars(sys.modules[fn.__module__]))


def _admits(declared: Any, value: object) -> bool:
    """Whether ``value`` is of the type ``declared`` (unions, tuples of given element types,
    generic sequences by their origin)."""
    origin, args = typing.get_origin(declared), typing.get_args(declared)
    if origin in (typing.Union, types.UnionType):
        return any(_admits(arg, value) for arg in args)
    if origin is tuple:
        return isinstance(value, tuple) and len(value) == len(args) and all(
            _admits(arg, item) for arg, item in zip(args, value, strict=True)
        )
    return isinstance(value, origin or declared)


def test_every_tz_parameter_is_typed_as_the_zones_it_takes() -> None:
    """docs/API.md: a zone is a name, a ``ZoneInfo`` or a fixed-offset ``datetime.timezone``,
    and the package is typed (``py.typed``); but ``tz`` was annotated ``str | None``, so a
    type-checked script passing ``tz=ZoneInfo("Europe/London")`` (which works) failed mypy
    with 'incompatible type "ZoneInfo"; expected "str | None"'. Each ``tz`` admits all four."""
    functions = [aion.build, aion.Map.predict, aion.Map.predict_series, aion.Map.plan,
                 aion.Map.export, aion.Map.picture]
    for fn in functions:
        for value in ("Europe/London", ZoneInfo("Europe/London"), UTC, None):
            assert _admits(_declared(fn, "tz"), value), (fn.__qualname__, value)


def test_a_plan_s_ends_are_typed_as_the_points_they_take(m: aion.Map) -> None:
    """A plan's start and goal (and ``path=`` of export and picture) may be 2 or 3 numbers
    (docs/API.md, and they work), but were annotated ``str | int``: a type checker refused
    ``m.plan((0.0, 0.0), "p2")``. They admit a point, which plans as the string point does."""
    point = (0.0, 0.0)
    for name in ("start", "goal"):
        assert _admits(_declared(aion.Map.plan, name), point)
        assert _admits(_declared(aion.Map.plan, name), "p2")
    for fn in (aion.Map.export, aion.Map.picture):
        assert _admits(_declared(fn, "path"), (point, "p2"))
        assert not _admits(_declared(fn, "path"), ("p2",))
    by_numbers = m.plan(point, "p2", time=T, tz="UTC")
    assert by_numbers.to_dict() == m.plan("0,0", "p2", time=T, tz="UTC").to_dict()


def test_to_ns_takes_zone_names_and_refuses_seconds_as_nanoseconds() -> None:
    ns = int(datetime(2026, 1, 12, 8, 40, tzinfo=UTC).timestamp()) * 10**9
    assert aion.to_ns(T, "UTC") == ns
    assert aion.to_ns(T) == ns  # UTC by default
    assert aion.to_ns(datetime(2026, 1, 12, 9, 40), "Europe/Berlin") == ns
    assert aion.to_ns(datetime(2026, 1, 12, 8, 40), ZoneInfo("UTC")) == ns
    assert aion.to_ns(np.int64(ns)) == ns
    with pytest.raises(InputError, match="read as nanoseconds") as caught:
        aion.to_ns(ns // 10**9)
    assert caught.value.hint is not None
    assert "* 10**9" in caught.value.hint
    with pytest.raises(InputError, match="not a time"):
        aion.to_ns(12.5)  # type: ignore[arg-type]


def test_a_float_time_is_refused_with_what_unix_seconds_are() -> None:
    """``time.time()`` (a float of UNIX seconds, what a notebook has at hand) was "not a
    time", with the hint every wrong type had; the hint now gives the call that reads it."""
    ns = int(datetime(2026, 1, 12, 8, 40, tzinfo=UTC).timestamp()) * 10**9
    seconds = ns / 10**9 + 0.5
    for given in (seconds, np.float64(seconds)):
        with pytest.raises(InputError, match="a float; integer times are nanoseconds") as caught:
            aion.to_ns(given)  # type: ignore[arg-type]
        hint = caught.value.hint
        assert hint is not None
        first, second = hint.split(": give ", 1)[1].split(", or ")
        scope = {"datetime": datetime, "timezone": timezone, "np": np}
        assert aion.to_ns(eval(first, scope)) == ns + 5 * 10**8  # what the hint says works
        assert aion.to_ns(eval(second.removesuffix(" nanoseconds"), scope)) == ns + 5 * 10**8
    with pytest.raises(InputError, match=r"not a time: nan$"):
        aion.to_ns(float("nan"))  # type: ignore[arg-type]


def test_a_float_of_nanoseconds_is_not_taken_for_seconds() -> None:
    """Nanoseconds as a float (``df["t_ns"].mean()``, ``float(ns)``): the hint read them as
    UNIX seconds, ``datetime.fromtimestamp(1.7682072e+18, ...)``, a year past 9999, which
    raises; it now says to round them to an int, which reads the time meant."""
    ns = int(datetime(2026, 1, 12, 8, 40, tzinfo=UTC).timestamp()) * 10**9
    for given in (float(ns), np.float64(ns), -float(ns)):
        with pytest.raises(InputError, match="a float; integer times are nanoseconds") as caught:
            aion.to_ns(given)  # type: ignore[arg-type]
        assert caught.value.hint == f"nanoseconds as a float: give round({float(given)!r}), an int"
    assert aion.to_ns(round(float(ns))) == ns  # exact: 1768207200 * 10**9 is a float exactly


@pytest.mark.parametrize(
    ("call", "fragment"),
    [
        (lambda m: m.predict(T, nodes=[12.0]), "not a node id"),
        (lambda m: m.predict(T, nodes=[None]), "not a node id"),
        # before: an empty list (a filter that came out empty) answered every entry
        (lambda m: m.predict(T, nodes=[]), "nodes is empty: it names no entry"),
        (lambda m: m.predict_series(T, T, nodes=(n for n in ())), "nodes is empty"),
        (lambda m: m.predict(T, top=2.5), "top must be a whole number"),
        (lambda m: m.predict(T, top="5"), "top must be a whole number"),
        (lambda m: m.predict(T, top=0), "top must be at least 1"),
        (lambda m: m.predict(T, at=[1.0]), "at must be a point"),
        (lambda m: m.predict(T, at=[1.0, float("nan")]), "must be finite"),
        # before: "at must be a number, got array([0., 0.])" of one row of points
        (lambda m: m.predict(T, at=np.zeros((2, 2))), r"at must be a point: .*shape \(2, 2\)"),
        (lambda m: m.plan(((0.0, 1.0), (2.0, 3.0)), "p2"), "start must be a point"),
        # before: "--at expects coordinates x,y[,z]", with the hint 'e.g. --at "3.5,-1.0"'
        (lambda m: m.predict(T, at="1,2,3,4"), "^at must be a point"),
        (lambda m: m.predict_series(T, T, at="kitchen"), "^at must be a point"),
        (lambda m: m.predict(T, nodes=["p4"], at=(1.0, 2.0)), "not both"),
        (lambda m: m.predict(T, historical=True), "not both"),
        (lambda m: m.predict(ns_seconds()), "read as nanoseconds"),
        (lambda m: m.predict_series(T, T, step=float("inf")), "step must be finite"),
        (lambda m: m.predict_series(T, T, step=None), "step must be a duration"),
        (lambda m: m.predict_series(T, T, step=[60]), "step must be a duration"),
        # before: read as true, and the time beside it refused as "not both" / a table
        (lambda m: m.predict(historical="no"), "historical must be True or False"),
        (lambda m: m.export("x/", historical="yes"), "historical must be True or False"),
        (lambda m: m.picture("x.png", historical=1), "historical must be True or False"),
        # before: its bytes read as the integer node ids 112, 52 ("node 112, 52 is not ...")
        (lambda m: m.predict(T, nodes=b"p4"), "nodes must be node ids .text., got bytes"),
        (lambda m: m.predict_series("2026-01-12 10:00", T, tz="UTC"), "end is before start"),
        (lambda m: m.plan("p1", "p2", speed="1.2"), "speed must be a number"),
        (lambda m: m.plan(None, "p2"), "start must be a node id"),
        (lambda m: m.plan((0.0,), "p2"), "start must be a point"),
        (lambda m: m.plan(-1, "p2"), "start must be a node id"),  # not an OverflowError
        (lambda m: m.plan("p1", 1 << 64), "goal must be a node id"),
        (lambda m: m.plan("p1", "p2", leave=(T,)), "leave must be two items"),
        (lambda m: m.plan("p1", "p2", leave="08:00..09:00"), "leave must be two items"),
        (lambda m: m.plan("p1", "p2", time=T, leave=(T, T)), "not both"),
        (lambda m: m.plan("p1", "p2", time=T, step="30m"), "step needs leave"),
        (lambda m: m.plan("p1", "p2", step=60.0), "step needs leave"),
        (lambda m: m.plan("p1", "p2", leave=(T, "2026-01-12 08:00")), "latest departure is before"),
        (lambda m: m.holdout([], radius=1.0), "no log given"),
        (lambda m: m.holdout(None), "logs must be a path"),
        # before: TypeError ('NoneType' / 'int' object is not iterable), or bytes read as the
        # paths 120, 46, ... ("path must be a path ..., got 120")
        (lambda m: aion.merge(None, "w.aion"), "paths must be a list of paths, got None"),
        (lambda m: aion.merge(3, "w.aion"), "paths must be a list of paths, got 3"),
        (lambda m: aion.merge(b"a.aion", "w.aion"), "paths must be a list of paths, got b'a"),
        (lambda m: aion.build(b"x.mcap"), "logs must be a path or a list of paths, got b'x"),
        # before: the topic "47" (the code of "/") looked for in the log
        (lambda m: m.holdout(["x.mcap"], detection_topics=b"/t"), "detection_topics must be"),
        (lambda m: m.holdout(["x.mcap"], frob=1), "unexpected keyword argument 'frob'"),
        (lambda m: m.holdout(["x.mcap"], radius=-5), "association radius"),
        (lambda m: m.holdout(["x.mcap"], radius=float("nan")), "association radius"),
        (lambda m: m.holdout(["x.mcap"], radius="1"), "association radius"),
    ],
)
def test_bad_arguments_are_one_typed_error(m: aion.Map, call: object, fragment: str) -> None:
    with pytest.raises(InputError, match=fragment):
        call(m)  # type: ignore[operator]


def ns_seconds() -> int:
    return int(datetime(2026, 1, 12, 8, 40, tzinfo=UTC).timestamp())  # seconds, not ns


def test_points_as_numbers_and_integer_node_ids(m: aion.Map) -> None:
    assert m.predict(T, tz="UTC", at=(5.8, 0.3)).records() == m.predict(
        T, tz="UTC", at="5.8,0.3"
    ).records()
    assert _ids(m.predict(T, tz="UTC", at=np.array([5.8, 0.3]))) == ["p3"]
    p4 = (ord("p") << 56) | 4
    assert _ids(m.predict(T, tz="UTC", nodes=[np.uint64(p4)])) == ["p4"]


def test_a_room_as_its_integer_id_is_a_room_for_plans(m: aion.Map) -> None:
    """The integer NodeSymbol value of a room plans from its place nearest the centre, as
    its id "R1" does (it was looked up among the places and refused)."""
    r1 = (ord("R") << 56) | 1
    by_int = m.plan(r1, "p0", time=T, tz="UTC")
    assert by_int.to_dict() == m.plan("R1", "p0", time=T, tz="UTC").to_dict()
    assert by_int.snapped[0]["room"] == "R1"


def test_cell_ids_as_predict_prints_them_are_read_back() -> None:
    """A map of hash cells only (a fixed sensor fed in memory): the ids predict prints
    (``c<key>``) select those cells again."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch

    t0 = aion.to_ns(T)
    mapper = Mapper(ModelConfig())
    mapper.set_fixed_sensor(t0, t0 + 3600 * 10**9)
    xyz = np.array([[0.2, 0.2, 0.0], [3.1, 1.2, 0.0], [3.2, 1.3, 0.0]])
    mapper.add_detections(DetectionBatch.from_arrays(t0 + np.arange(3) * 10**9, xyz, np.zeros(3)))
    mapper.advance(t0 + 3600 * 10**9)
    cells = aion.Map.from_state(mapper.state, timezone="UTC")
    ids = _ids(cells.predict(historical=True))
    assert len(ids) == 2
    assert all(i.startswith("c") for i in ids)
    for cell in ids:
        assert _ids(cells.predict(historical=True, nodes=[cell])) == [cell]
    with pytest.raises(InputError, match="c123 is not in the map"):
        cells.predict(historical=True, nodes=["c123"])


def test_a_number_s_hint_names_what_was_given(m: aion.Map) -> None:
    """``speed=True``, ``at=(True, 1.0)`` or ``speed=[1.2]`` had the hint "an int or a float,
    not a string"."""
    for call, given in [
        (lambda: m.plan("p1", "p2", speed=True), "not a bool"),
        (lambda: m.predict(T, at=(True, 1.0)), "not a bool"),
        (lambda: m.plan("p1", "p2", speed=[1.2]), "not a list"),
        (lambda: m.plan("p1", "p2", speed="1.2"), "not a string"),
    ]:
        with pytest.raises(InputError, match="must be a number") as caught:
            call()
        assert caught.value.hint == f"an int or a float, {given}"


def test_paths_must_be_paths(tmp_path: Path, m: aion.Map) -> None:
    for bad in (None, 3, ["x"], b"x.aion"):
        with pytest.raises(InputError, match="must be a"):
            aion.Map.load(bad)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="must be a"):
        m.save(None)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="path must be two items"):
        m.export(tmp_path / "out", time=T, path=("p1", "p2", "p3"))  # type: ignore[arg-type]
    with pytest.raises(InputError, match="path must be two items"):
        m.picture(tmp_path / "m.png", time=T, path=("p1",))  # type: ignore[arg-type]


def test_output_refusals_name_the_path_not_a_command_option(
    m: aion.Map, tmp_path: Path
) -> None:
    """``m.export("Y.JSON")`` was refused with the hint ``-o Y.json``, an option of the
    command an API caller does not run (so were a folder given for one file, and
    ``m.save(folder)``: ``e.g. -o office.aion``): the refusals now name the path given and
    the spelling to give instead."""
    folder = tmp_path / "folder"
    folder.mkdir()
    cases = [
        (lambda: m.export(tmp_path / "Y.JSON", time=T), "Y.JSON", "name it Y.json"),
        (lambda: m.export(folder, time=T, format="dsg"), f"{folder} is a folder",
         f"e.g. {folder / 'dsg.json'}"),
        (lambda: m.export(folder, time=T, format="mcap"), f"{folder} is a folder",
         f"e.g. {folder / 'scene.mcap'}"),
        (lambda: m.export(tmp_path / "s.ply", time=T, format="mcap"),
         "s.ply' disagree: .ply is the suffix of format ply", "name it s.mcap"),
        (lambda: m.save(folder), f"{folder}: it is a folder", f"e.g. {folder / 'office.aion'}"),
    ]
    for call, says, hint in cases:
        with pytest.raises(InputError) as caught:
            call()
        message, given = caught.value.message, caught.value.hint or ""
        assert says in message
        assert hint in given
        said = f"{message} {given}".replace(str(tmp_path), "TMP")  # (pytest-of-root)
        assert not re.search(r"(^|\s)(-o|--[a-z])", said), said
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"]


def test_an_unknown_keyword_is_named_with_the_keywords_there_are(
    office: Office, m: aion.Map, tmp_path: Path
) -> None:
    """``aion.build(logs, bogus=1)`` raised Python's bare ``TypeError`` (no hint, not an
    ``aion.InputError`` as docs/API.md promises for every refused argument); now it is an
    ``UnknownArgumentError``, both, naming the keyword, a close spelling and the keywords the
    function takes (its signature's, so the list cannot drift from it)."""
    import inspect

    from aion_cli.errors import UnknownArgumentError

    calls = [
        (lambda: aion.build(office.log, tmp_path / "b.aion", detection_topic="/tracks"),
         aion.build, "detection_topic", "detection_topics"),
        (lambda: aion.merge([office.map], tmp_path / "m.aion", linage="same"),
         aion.merge, "linage", "lineage"),
        (lambda: aion.compact(office.map, tmp_path / "c.aion", bogus=1),
         aion.compact, "bogus", None),
        (lambda: m.predict(T, tops=3), aion.Map.predict, "tops", "top"),
        (lambda: aion.Map.load(office.map, strict=True), aion.Map.load, "strict", None),
    ]
    for call, function, name, close in calls:
        with pytest.raises(UnknownArgumentError) as caught:
            call()
        error = caught.value
        assert isinstance(error, InputError)
        assert isinstance(error, TypeError)  # what Python raises: except TypeError still works
        where = function.__qualname__
        assert error.message == f"{where}() got an unexpected keyword argument {name!r}"
        takes = [p for p in inspect.signature(function).parameters if p not in ("self", "cls")]
        assert error.hint == (f"did you mean {close}? " if close else "") + (
            f"{where}() takes: {', '.join(takes)}"
        )
    assert not any(tmp_path.iterdir())  # refused before anything was read or written
    assert _ids(m.predict(T, top=1, layer="places")) != []  # the keywords it takes still work


def test_a_loaded_state_is_not_written_again(m: aion.Map, tmp_path: Path) -> None:
    """Its queries counted its open window as closed in place: writing it would add that
    window again at every round trip (674, 675, 676 windows...)."""
    m.predict(T, tz="UTC")
    with pytest.raises(InputError, match="read from a map file for queries"):
        aion.Map.from_state(m.state)
    with pytest.raises(InputError, match="needs an engine MapState"):
        aion.Map.from_state({})  # type: ignore[arg-type]
    copy = m.save(tmp_path / "copy.aion")
    assert copy.read_bytes() == Path(m.path).read_bytes()  # type: ignore[arg-type]
    again = aion.Map.load(copy)
    assert again.predict(T, tz="UTC").records() == m.predict(T, tz="UTC").records()
    assert again.manifest.counts == m.manifest.counts


def test_save_writes_the_map_as_loaded_and_an_overwritten_file_is_refused(
    office: Office, tmp_path: Path
) -> None:
    live = tmp_path / "live.aion"
    shutil.copy(office.map, live)
    loaded = aion.Map.load(live)
    before = live.read_bytes()
    answer = loaded.predict(T, tz="UTC").records()
    # replaced atomically (as aion writes maps): the loaded map answers and saves as loaded
    other = tmp_path / "other.aion"
    shutil.copy(office.map, other)
    with other.open("r+b") as fh:  # a different file of the same kind
        fh.seek(0, os.SEEK_END)
        fh.write(b"\0" * 7)
    os.replace(other, live)
    assert loaded.predict(T, tz="UTC").records() == answer
    saved = loaded.save(tmp_path / "snap.aion")
    assert saved.read_bytes() == before
    live.unlink()  # deleted: still saved as loaded
    assert loaded.save(tmp_path / "snap2.aion").read_bytes() == before
    # overwritten in place (cp over it): refused, never read (a bus error with a memory map)
    victim = tmp_path / "victim.aion"
    shutil.copy(office.map, victim)
    held = aion.Map.load(victim)
    with victim.open("r+b") as fh:
        fh.truncate(100)
    with pytest.raises(MapFileError, match="overwritten in place"):
        held.predict(T, tz="UTC")
    with pytest.raises(MapFileError, match="overwritten in place"):
        held.save(tmp_path / "never.aion")
    assert not (tmp_path / "never.aion").exists()


def test_export_s_force_is_a_yes_or_no(m: aion.Map, tmp_path: Path) -> None:
    """``force`` is checked as ``historical`` is: before, ``force="no"`` (any string is true)
    replaced a file of aion's that no export into the folder wrote, which ``force=False``
    refuses."""
    out, other = tmp_path / "out", tmp_path / "other"
    m.export(out, time=T, tz="UTC")
    m.export(other, historical=True)  # entries of another time: other bytes
    shutil.copy(other / "entries.csv", out / "entries.csv")  # aion's, not written there
    kept = (out / "entries.csv").read_bytes()
    with pytest.raises(InputError, match="no export into"):
        m.export(out, time=T, tz="UTC")
    with pytest.raises(InputError, match="force must be True or False, got 'no'"):
        m.export(out, time=T, tz="UTC", force="no")  # type: ignore[arg-type]
    assert (out / "entries.csv").read_bytes() == kept
    assert out / "entries.csv" in m.export(out, time=T, tz="UTC", force=np.True_)
    assert (out / "entries.csv").read_bytes() != kept


def test_a_map_given_for_its_file_is_told_where_its_file_is(
    office: Office, tmp_path: Path
) -> None:
    """``aion.merge([m1, m2], ...)`` (maps where their files are meant) was "map must be a
    path ..., got <aion.Map ...>" with the hint ``e.g. "office.aion"``; the hint now says
    where a map's file is, and that a map in memory has none until saved. The message no
    longer formats the map's repr, which reads its state."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper

    m = aion.Map.load(office.map)
    for call in (
        lambda: aion.merge([m, office.map], tmp_path / "week.aion"),
        lambda: aion.compact(m, tmp_path / "robot.aion"),
        lambda: aion.build([office.log], output=tmp_path / "b.aion", continue_from=m),
    ):
        with pytest.raises(InputError, match=re.escape(f"got the aion.Map {office.map}")) as e:
            call()
        assert e.value.hint == "give the map's file: its .path"
    assert m._source.loaded is None  # the error read none of the map's state
    memory = aion.Map.from_state(Mapper(ModelConfig()).state, timezone="UTC")
    with pytest.raises(InputError, match=re.escape("got the aion.Map <memory>")) as e:
        aion.compact(memory, tmp_path / "robot.aion")
    assert e.value.hint is not None
    assert "save it first" in e.value.hint


def test_a_keyword_given_by_position_is_named(m: aion.Map, tmp_path: Path) -> None:
    """``m.predict(T, "UTC")`` (``tz`` meant) was Python's bare ``TypeError: Map.predict()
    takes from 1 to 2 positional arguments but 3 were given``: ``self`` counted, neither the
    positional argument nor the keywords named, and no ``InputError``, though the API refuses
    every other wrong argument with one. Now the ``UnknownArgumentError`` (an ``InputError``
    and still a ``TypeError``) of an unknown keyword, naming them."""
    from aion_cli.errors import UnknownArgumentError

    with pytest.raises(UnknownArgumentError) as caught:
        m.predict(T, "UTC")  # type: ignore[misc]
    assert isinstance(caught.value, InputError)
    assert isinstance(caught.value, TypeError)
    assert str(caught.value) == "Map.predict() takes 1 positional argument (time) but 2 were given"
    assert caught.value.hint == (
        "give the others by keyword: historical=, tz=, layer=, nodes=, at=, top="
    )
    with pytest.raises(InputError, match=r"takes 2 positional arguments \(paths, output\)"):
        aion.merge([m.path, m.path], tmp_path / "w.aion", "graph.json")  # type: ignore[misc]
    with pytest.raises(InputError, match=r"Map\.load\(\) takes 1 positional") as caught:
        aion.Map.load(str(m.path), str(m.path))  # type: ignore[call-arg]
    assert caught.value.hint == "Map.load() takes nothing else"
    assert not (tmp_path / "w.aion").exists()


def test_numpy_flags_are_read_as_the_flags_they_are(m: aion.Map, tmp_path: Path) -> None:
    """``historical=mask.any()`` (a ``numpy.bool``) was refused, "historical must be True or
    False, got np.True_", though yes-or-no arguments take numpy's (api_checks.flag): numpy 2
    names the type ``bool``, not ``bool_``, so the check by name missed it."""
    observed = m.predict(historical=np.array([False, True]).any())
    assert observed.to_dict() == m.predict(historical=True).to_dict()
    at_t = m.predict(T, tz="UTC", historical=np.False_)
    assert at_t.to_dict() == m.predict(T, tz="UTC").to_dict()
    png = m.picture(tmp_path / "h.png", historical=np.True_)
    assert png.read_bytes().startswith(b"\x89PNG")
    with pytest.raises(InputError, match="historical must be True or False"):
        m.predict(historical=np.int64(1))  # type: ignore[arg-type]
