"""The Python API at its boundary, for ``aion.build``, ``aion.merge`` (and ``aion.to_ns``):
wrong types and values of their arguments are one typed ``InputError`` naming the argument
(never a ``TypeError`` or ``AttributeError`` from inside), plausible slips are read as meant
(one topic, a config dict, a zone as the command names it), and a progress object written as
the docs give it is called.

Split from tests/cli/test_api_arguments.py (the map's queries, saving a loaded map)."""

from __future__ import annotations

from pathlib import Path
from zoneinfo import ZoneInfo

import pytest

import aion_cli as aion
from aion_cli.errors import InputError
from tests.cli.conftest import Office

T = "2026-01-12 08:40"  # the office log's Monday (tests/cli/logdata.py)


def test_build_arguments(office: Office, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="logs must be a path"):
        aion.build(None)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="must be a"):
        aion.build([None])  # type: ignore[list-item]
    with pytest.raises(InputError, match="workers must be a whole number"):
        aion.build(office.log, tmp_path / "w.aion", workers=2.5)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="observed span must be two items"):
        aion.build(office.log, tmp_path / "o.aion", observed=[("2026-01-12 08:00",)])  # type: ignore[list-item]
    with pytest.raises(InputError, match="config must be a ModelConfig"):
        aion.build(office.log, tmp_path / "c.aion", config=[1])  # type: ignore[arg-type]
    # before: bool("no") is True, so derive_graph="no" derived a graph and part="no" wrote
    # a part map; progress="yes" failed inside with AttributeError: 'str' ... 'start'
    with pytest.raises(InputError, match="derive_graph must be True or False"):
        aion.build(office.log, tmp_path / "d.aion", derive_graph="no")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="part must be True or False"):
        aion.build(office.log, tmp_path / "p.aion", part="no")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="progress must have start") as refused:
        aion.build(office.log, tmp_path / "g.aion", progress="yes")  # type: ignore[arg-type]
    # the hint names the type docs/API.md names (it named build_report.NoProgress)
    assert "aion_cli.api_make.Progress" in (refused.value.hint or "")
    assert "aion_cli.api_make.Progress" in (
        Path(__file__).resolve().parents[2] / "docs" / "API.md"
    ).read_text(encoding="utf-8")
    with pytest.raises(InputError, match="progress must have start"):
        aion.merge([office.map, office.map], tmp_path / "m.aion", progress=True)  # type: ignore[arg-type]
    assert not any(tmp_path.glob("[dpgm].aion"))
    # one topic alone is a topic, a dict is a config, one span alone is one span (read, then
    # set aside: the office log's robot trajectory says what was observed)
    with pytest.warns(aion.AionWarning, match="observed= ignored"):
        built = aion.build(
            office.log,
            tmp_path / "ok.aion",
            detection_topics="/tracks",
            config={"bins": 8},
            observed=("2026-01-12 08:00", "2026-01-12 09:00"),
            tz=ZoneInfo("UTC"),
        )
    assert built.report is not None
    assert built.report.detection_topics == ["/tracks"]  # type: ignore[union-attr]


def test_build_names_its_zone_as_the_command_does(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``aion.build(tz=...)`` stored the name as given ("UTC+5:30", "utc") where ``aion build
    --tz`` stores "UTC+05:30" and "UTC", so the command refused to continue or merge the
    API's map ("--tz UTC+05:30 differs", "different model parameters"), and tz="local" was
    "unknown time zone 'local'"."""
    from tests.cli.conftest import run

    india = aion.build(office.log, tmp_path / "india.aion", tz="UTC+5:30")
    assert india.timezone == "UTC+05:30"
    assert aion.build(office.log, tmp_path / "utc.aion", tz="utc").timezone == "UTC"
    monkeypatch.setenv("TZ", "Asia/Kolkata")
    assert aion.build(office.log, tmp_path / "local.aion", tz="local").timezone == "Asia/Kolkata"
    cli = run("build", office.log, "-o", tmp_path / "cli.aion", "--tz", "UTC+05:30", "-q")
    assert cli.exit_code == 0, cli.stderr
    assert aion.Map.load(tmp_path / "cli.aion").timezone == india.timezone


def test_merge_refuses_a_nav_layer_without_a_graph(office: Office, tmp_path: Path) -> None:
    other = tmp_path / "other.aion"
    aion.build(office.log, other, config={"bins": 8, "cell_size": 0.25})
    with pytest.raises(InputError, match='nav_layer="NOPE" chooses the layer of a graph='):
        aion.merge([office.map, other], tmp_path / "x.aion", nav_layer="NOPE")


def test_names_of_frames_topics_and_formats_must_be_strings(office: Office, tmp_path: Path) -> None:
    """Before: ``map_frame=3`` or ``base_frame=3`` failed inside the build with
    ``AttributeError: 'int' object has no attribute 'strip'``; ``Map.holdout(...,
    map_frame=3)`` silently used the map's own frame instead; ``scheduler=3`` was taken."""
    m = aion.Map.load(office.map)
    for name in ("map_frame", "base_frame", "graph_topic", "log_format", "scheduler"):
        with pytest.raises(InputError, match=f"^{name} must be a string, got 3"):
            aion.build(office.log, tmp_path / "f.aion", **{name: 3})  # type: ignore[arg-type]
    for name in ("map_frame", "base_frame", "graph_topic", "log_format"):
        with pytest.raises(InputError, match=f"^{name} must be a string, got 3"):
            m.holdout([office.log], **{name: 3})
    assert not (tmp_path / "f.aion").exists()
    layered = aion.build(office.log, tmp_path / "n.aion", nav_layer=3)  # a layer key, as "3"
    assert layered.report.detections_used == office.build["detections"]["used"]


class _Phases:
    """A progress object written as the API's words give it: ``start(description, total,
    unit)`` and ``advance(n)``, no defaults."""

    def __init__(self) -> None:
        self.units: list[str] = []
        self.done = 0

    def start(self, description: str, total: int, unit: str) -> None:
        self.units.append(unit)

    def advance(self, n: int) -> None:
        self.done += n


def test_a_progress_object_with_start_description_total_unit_is_called(
    office: Office, tmp_path: Path
) -> None:
    """The hint and docs say progress= takes an object with ``start(description, total, unit)``
    and ``advance(n)``; one written so failed inside the build with "TypeError: start() missing
    1 required positional argument: 'unit'" (the build's phases left ``unit`` to a default).
    Every phase now passes its unit; the map is the one built without progress."""
    phases = _Phases()
    built = aion.build(office.log, tmp_path / "p.aion", progress=phases)
    assert phases.units
    assert all(isinstance(u, str) and u for u in phases.units)
    assert "msgs" in phases.units
    assert phases.done > 0
    plain = aion.build(office.log, tmp_path / "q.aion")
    assert built.predict(T, tz="UTC").records() == plain.predict(T, tz="UTC").records()
    merged = _Phases()
    later = aion.build(office.log, tmp_path / "part.aion", part=True)
    aion.merge([later.path], tmp_path / "m.aion", progress=merged)  # type: ignore[list-item]
    assert merged.units == ["maps", "maps"]


def test_to_ns_refuses_an_extra_argument_as_the_api_does() -> None:
    """``aion.to_ns(t, "UTC", x)`` was Python's bare ``TypeError: to_ns() takes from 1 to 2
    positional arguments but 3 were given`` (no ``InputError``), ``to_ns(t, zon=...)`` alike;
    now the ``UnknownArgumentError`` ``Map.predict`` raises, naming its arguments."""
    from aion_cli.errors import UnknownArgumentError

    with pytest.raises(UnknownArgumentError) as caught:
        aion.to_ns(T, "UTC", "Europe/Berlin")  # type: ignore[call-arg]
    assert isinstance(caught.value, InputError)
    assert isinstance(caught.value, TypeError)  # code catching TypeError still does
    assert str(caught.value) == "to_ns() takes 2 positional arguments (time, zone) but 3 were given"
    with pytest.raises(UnknownArgumentError, match="unexpected keyword argument 'zon'") as caught:
        aion.to_ns(T, zon="UTC")  # type: ignore[call-arg]
    assert caught.value.hint == "did you mean zone? to_ns() takes: time, zone"
    assert aion.to_ns(T, zone="UTC") == 1_768_207_200 * 10**9  # 2026-01-12 08:40 UTC


def test_a_zone_keyword_given_by_another_of_the_apis_names_hints_the_right_one() -> None:
    """The zone is ``tz=`` in queries and ``build``, ``zone=`` in ``to_ns`` and ``timezone=``
    in ``Map.from_state``; ``aion.to_ns(t, tz="UTC")`` was hinted only "to_ns() takes: time,
    zone" (no spelling is close to ``tz``). The hint names the one meant."""
    from aion_cli.errors import UnknownArgumentError

    with pytest.raises(UnknownArgumentError) as caught:
        aion.to_ns(T, tz="UTC")  # type: ignore[call-arg]
    assert caught.value.hint == "did you mean zone? to_ns() takes: time, zone"
    with pytest.raises(UnknownArgumentError) as caught:
        aion.Map.from_state(None, tz="UTC")  # type: ignore[arg-type, call-arg]
    assert caught.value.hint == "did you mean timezone? Map.from_state() takes: state, timezone"
    with pytest.raises(UnknownArgumentError) as caught:
        aion.build("x.mcap", timezone="UTC")  # type: ignore[call-arg]
    assert (caught.value.hint or "").startswith("did you mean tz? build() takes: logs, output, ")



def test_without_output_the_map_is_written_where_aion_build_writes_it(
    office: Office, tmp_path: Path
) -> None:
    """docs/API.md did not say where ``aion.build(logs)`` writes without ``output``: beside
    the first log, named as it with ``.aion``, as ``aion build LOG`` (and continued maps over
    ``continue_from``'s file, as ``--map``)."""
    import shutil

    log = tmp_path / "monday.mcap"
    shutil.copy(office.log, log)
    built = aion.build(log)
    assert built.path == tmp_path / "monday.aion"
    assert [i.name for i in aion.Map.load(built.path).manifest.inputs] == ["monday.mcap"]


def test_build_takes_its_logs_from_a_generator(office: Office, tmp_path: Path) -> None:
    """docs/API.md takes paths as "any other iterable" and ``build``'s annotation admits a
    generator of logs, but ``aion.build(p for p in logs)`` was refused 'no log given': the
    build read its logs twice (once for the zone they declare), the generator was empty the
    second time. The map is the one of the list."""
    listed = aion.build([office.log], tmp_path / "listed.aion")
    generated = aion.build((p for p in [office.log]), tmp_path / "generated.aion")
    assert generated.report.detections_used == listed.report.detections_used > 0
    a, b = generated.predict(T).to_dict(), listed.predict(T).to_dict()
    assert a.pop("map") != b.pop("map")
    assert a == b


def test_a_path_from_home_with_a_tilde_says_python_does_not_expand_it(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``aion.build("~/logs/run.mcap")``, as written in a shell, was told its output folder
    '~' does not exist, with the hint ``mkdir -p '~'`` (a folder named '~' here); a map to
    load was 'not found'. Each path is refused naming the tilde, with its expanded form; a
    file or folder really named '~' in the current folder is taken as it is."""
    import os

    monkeypatch.chdir(tmp_path)
    calls = {
        "log": lambda: aion.build("~/run.mcap"),
        "output": lambda: aion.build(office.log, "~/office.aion"),
        "path": lambda: aion.Map.load("~/office.aion"),
    }
    for what, call in calls.items():
        with pytest.raises(InputError, match=f"^{what} '~/[a-z.]+' starts with '~', which Python "
                           "does not expand") as refused:
            call()
        assert os.path.expanduser("~/") in (refused.value.hint or "")
        assert not (tmp_path / "~").exists()
    with pytest.raises(aion.AionError, match="is a folder"):  # "." has no first part
        aion.compact(office.map, ".")
    (tmp_path / "~").mkdir()
    copy = aion.Map.load(office.map).save("~/copy.aion")
    assert (tmp_path / "~" / "copy.aion").is_file()
    assert copy == Path("~/copy.aion")


def test_merge_takes_one_path_alone_as_build_does(office: Office, tmp_path: Path) -> None:
    """``aion.merge("part.aion", out)``: one path alone is one map, as ``aion.build`` takes one
    log and ``aion merge PART.aion`` one part map (it was refused: 'merge takes a list of map
    files'); the map made equals the one of the list ``[part]``, and a full map alone is
    refused as the command refuses it, a merge needing two."""
    part = aion.build(office.log, tmp_path / "part.aion", part=True)
    alone = aion.merge(str(part.path), tmp_path / "alone.aion")
    listed = aion.merge([part.path], tmp_path / "listed.aion")
    assert alone.report.detections == listed.report.detections > 0  # type: ignore[union-attr]
    a, b = alone.predict(T).to_dict(), listed.predict(T).to_dict()
    assert a.pop("map") != b.pop("map")
    assert a == b
    assert a["entries"]
    with pytest.raises(InputError, match="a merge needs at least two maps"):
        aion.merge(office.map, tmp_path / "full.aion")
