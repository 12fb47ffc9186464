"""Part maps (``aion build --part``) and their exact ``aion merge``.

A part holds its closed days unscored; ``aion merge`` joins the parts in time order and scores
each held day against everything before it, so merging parts gives the map of one build of all
their logs (engine/shards.py), which merging ordinary maps cannot once a map closed a day of
its own (it scored that day against its own history: merge approximation 2).
Logs: ``tests/cli/logdata.py`` (a robot at a fixed pose, people at fixed spots, the office
graph in every scene-graph message), two hours each on different days.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.compare import differences
from aion_cli.mapquery import load_map
from tests.cli.conftest import assert_one_line_error, run
from tests.cli.logdata import write_office_log

HOUR_S = 3600


def _logs(folder: Path, days: list[float]) -> list[Path]:
    paths = []
    for k, day in enumerate(days):
        path = folder / f"day{k}.mcap"
        write_office_log(path, shift_s=int(day * 24 * HOUR_S), duration_s=2 * HOUR_S)
        paths.append(path)
    return paths


def _each_built(folder: Path, logs: list[Path], stem: str, *options: str) -> list[Path]:
    """A map of each log on its own, ``folder/{stem}{k}.aion`` (``--part`` among
    ``options`` for part maps)."""
    maps = []
    for k, log in enumerate(logs):
        out = folder / f"{stem}{k}.aion"
        assert run("build", log, "-o", out, "-q", *options).exit_code == 0
        maps.append(out)
    return maps


def _state(path: Path) -> object:
    return load_map(path, writable=True).state


def test_merging_parts_equals_one_build_of_all_logs(tmp_path: Path) -> None:
    logs = _logs(tmp_path, [0, 1, 3, 3.4])  # the last two on the same day
    whole = tmp_path / "whole.aion"
    assert run("build", *logs, "-o", whole, "--workers", "1", "-q").exit_code == 0
    parts = _each_built(tmp_path, logs, "part", "--part")
    merged = tmp_path / "merged.aion"
    result = run("merge", *reversed(parts), "-o", merged, "--format", "json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert doc["parts"] == 4
    assert not [n for n in doc["notes"] if "not exactly" in n]
    assert differences(_state(whole), _state(merged)) == []  # type: ignore[arg-type]
    # ordinary maps of one day each merge as one build too: none closed a day, so each day
    # is scored at the merge against every day before it, and the last two maps' day is one
    # pending day (merge approximation 4 no longer applies: stop 71)
    ordinary = _each_built(tmp_path, logs, "map")
    assert run("merge", *ordinary, "-o", tmp_path / "ord.aion", "-q").exit_code == 0
    assert differences(_state(whole), _state(tmp_path / "ord.aion")) == []  # type: ignore[arg-type]
    # an ordinary map that closed a day (days 1 and 3 in one) scored day 1 against its own
    # history only (merge approximation 2): the merge differs
    rest = tmp_path / "rest.aion"
    assert run("build", *logs[1:], "-o", rest, "--workers", "1", "-q").exit_code == 0
    assert run("merge", ordinary[0], rest, "-o", tmp_path / "two.aion", "-q").exit_code == 0
    assert differences(_state(whole), _state(tmp_path / "two.aion")) != []  # type: ignore[arg-type]


def test_parts_that_overlap_in_time_are_refused(tmp_path: Path) -> None:
    # two recordings of the same two hours (the second an hour later, so the two overlap):
    # a part joins only after every window of the maps before it, so instead of an internal
    # error deep in the join (as before) the merge says why and writes nothing
    first = tmp_path / "a.mcap"
    second = tmp_path / "b.mcap"
    write_office_log(first, duration_s=2 * HOUR_S)
    write_office_log(second, shift_s=HOUR_S, duration_s=2 * HOUR_S)
    parts = []
    for log in (first, second):
        part = log.with_suffix(".aion")
        assert run("build", log, "--part", "-o", part, "-q").exit_code == 0
        parts.append(part)
    merged = tmp_path / "merged.aion"
    result = run("merge", *parts, "-o", merged)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "b.aion overlaps the maps before it in time")
    assert "aion build LOG1 LOG2 --part" in result.stderr
    assert not merged.exists()


def test_a_part_map_saves_and_continues_its_held_days(tmp_path: Path) -> None:
    a, b = _logs(tmp_path, [0, 2])
    both = tmp_path / "both.aion"
    assert run("build", a, b, "--part", "-o", both, "-q").exit_code == 0
    cont = tmp_path / "cont.aion"
    assert run("build", a, "--part", "-o", cont, "-q").exit_code == 0
    assert run("build", b, "--map", cont, "-q").exit_code == 0  # a part continues as a part
    state = _state(cont)
    assert state.deferred is not None  # type: ignore[attr-defined]
    assert len(state.deferred.days) == 1  # type: ignore[attr-defined]  # day 0; day 2 pending
    assert differences(_state(both), state) == []  # type: ignore[arg-type]



def test_a_part_map_continues_with_workers_as_in_sequence(tmp_path: Path) -> None:
    # A week's part map grown day by day: two later logs are two shards, which join only an
    # ordinary map; with --workers 2 the build stopped on an internal error (ValueError)
    a, b, c = _logs(tmp_path, [0, 2, 3])
    whole = tmp_path / "whole.aion"
    assert run("build", a, b, c, "--part", "-o", whole, "-q", "--workers", "1").exit_code == 0
    cont = tmp_path / "cont.aion"
    assert run("build", a, "--part", "-o", cont, "-q").exit_code == 0
    result = run("build", b, c, "--map", cont, "--workers", "2", "--format", "json")
    assert result.exit_code == 0, result.output
    notes = json.loads(result.output)["notes"]
    assert [n for n in notes if n.startswith("--map is a part map (--part)")]
    assert differences(_state(whole), _state(cont)) == []  # type: ignore[arg-type]

def test_one_part_map_merged_alone_is_the_map_of_its_logs(tmp_path: Path) -> None:
    """A part map holds its days unscored; ``aion merge PART -o MAP`` scores them in time
    order: the map one build of the same logs gives. An ordinary map alone is refused."""
    logs = _logs(tmp_path, [0, 1, 3])
    part = tmp_path / "part.aion"
    assert run("build", *logs, "--part", "-o", part, "-q").exit_code == 0
    assert len(_state(part).deferred.days) == 2  # type: ignore[attr-defined]
    shown = json.loads(run("info", part, "--format", "json").stdout)
    assert shown["part"] == {"held_days": 2}
    assert "2 closed days held unscored, and the last day open" in " ".join(
        run("info", part).stdout.split()
    )
    whole = tmp_path / "whole.aion"
    assert run("build", *logs, "-o", whole, "--workers", "1", "-q").exit_code == 0
    alone = tmp_path / "alone.aion"
    merged = run("merge", part, "-o", alone, "-q", "--format", "json")
    assert merged.exit_code == 0, merged.stderr
    assert json.loads(merged.stdout)["lineage_reason"] == "one map"  # not "0 of 0 ids"
    assert differences(_state(whole), _state(alone)) == []  # type: ignore[arg-type]
    assert run("predict", alone, "--top", "1").exit_code == 0
    assert "part" not in json.loads(run("info", alone, "--format", "json").stdout)
    refused = run("merge", whole, "-o", tmp_path / "again.aion")
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "whole.aion is a map already")


def test_a_part_map_cannot_forecast(tmp_path: Path) -> None:
    (log,) = _logs(tmp_path, [0])
    part = tmp_path / "part.aion"
    assert run("build", log, "--part", "-o", part, "-q").exit_code == 0
    result = run("predict", part, "--time", "2026-11-30 08:00")
    assert result.exit_code == 2
    assert_one_line_error(result.output, "part map", "aion merge")
    # what was observed neither: the error said 'it cannot forecast' to --historical too
    for args in (("predict", part, "--historical"), ("export", part, "--historical", "-o",
                                                     tmp_path / "out")):
        result = run(*args)
        assert result.exit_code == 2
        assert_one_line_error(result.output, "neither a forecast nor what was observed")


def test_part_cannot_continue_an_ordinary_map(tmp_path: Path) -> None:
    a, b = _logs(tmp_path, [0, 2])
    out = tmp_path / "map.aion"
    assert run("build", a, "-o", out, "-q").exit_code == 0
    result = run("build", b, "--map", out, "--part")
    assert result.exit_code == 2
    assert_one_line_error(result.output, "--part cannot continue an ordinary map")


@pytest.mark.parametrize(
    "member", ["held0_live", "held0_windows", "held_drift_low", "held_group_keys"]
)
def test_a_part_map_with_a_broken_held_day_is_refused(tmp_path: Path, member: str) -> None:
    from aion_cli.engine.state import MapState
    from aion_cli.errors import MapCorruptError

    a, b = _logs(tmp_path, [0, 2])
    part = tmp_path / "part.aion"
    assert run("build", a, b, "--part", "-o", part, "-q").exit_code == 0
    arrays, meta = _state(part).to_arrays()  # type: ignore[attr-defined]
    arrays = {k: v for k, v in arrays.items() if k != member}
    with pytest.raises(MapCorruptError, match="held"):
        MapState.from_arrays(arrays, meta)


def test_a_merged_map_keeps_its_merge_provenance_when_continued(tmp_path: Path) -> None:
    """``merged_from`` / ``lineage`` are manifest fields: ``aion info`` shows them, and a
    build that continues the merged map keeps them."""
    a, b, c = _logs(tmp_path, [0, 2, 4])
    maps = []
    for k, log in enumerate((a, b)):
        one = tmp_path / f"m{k}.aion"
        assert run("build", log, "-o", one, "-q").exit_code == 0
        maps.append(one)
    merged = tmp_path / "merged.aion"
    assert run("merge", *maps, "-o", merged, "-q").exit_code == 0
    assert run("build", c, "--map", merged, "-q").exit_code == 0
    info = run("info", merged, "--format", "json")
    assert info.exit_code == 0, info.output
    doc = json.loads(info.output)
    text = json.dumps(doc)
    assert "merged_from" in text
    assert "m0.aion" in text
    assert "m1.aion" in text
    assert '"lineage": "same"' in text


def test_merged_and_continued_maps_describe_every_log_they_observed(tmp_path: Path) -> None:
    """Without a robot trajectory each log is a fixed sensor over the windows it recorded:
    a map merged from parts, or continued with ``--map``, describes all of them, as one build
    of every log does (it used to keep one part's description, or join them with ``+``)."""
    from aion_cli.formats.mapfile import read_manifest

    logs = []
    for k, day in enumerate([0, 1, 1.5]):
        path = tmp_path / f"fixed{k}.mcap"
        write_office_log(path, tf=False, shift_s=int(day * 24 * HOUR_S), duration_s=HOUR_S)
        logs.append(path)
    whole = tmp_path / "whole.aion"
    assert run("build", *logs, "-o", whole, "--workers", "1", "-q").exit_code == 0
    expected = read_manifest(whole)["observation"]
    assert expected.startswith("fixed sensor over the 18 windows with messages (18 of the ")
    parts = []
    for k, log in enumerate(logs):
        part = tmp_path / f"p{k}.aion"
        assert run("build", log, "--part", "-o", part, "-q").exit_code == 0
        assert "the 6 windows" in read_manifest(part)["observation"]
        parts.append(part)
    merged = tmp_path / "merged.aion"
    assert run("merge", *parts, "-o", merged, "-q").exit_code == 0
    assert read_manifest(merged)["observation"] == expected
    continued = tmp_path / "continued.aion"
    assert run("build", logs[0], "-o", continued, "-q").exit_code == 0
    for log in logs[1:]:
        assert run("build", "--map", continued, log, "-q").exit_code == 0
    assert read_manifest(continued)["observation"] == expected


def test_a_map_observed_by_a_robot_and_a_fixed_sensor_names_both() -> None:
    from aion_cli.engine.observation import ObservationSource
    from aion_cli.fixed_sensor import fixed_sensor_summary, fixed_sensor_text, map_observation_text

    delta = 600 * 10**9
    source = ObservationSource()
    assert fixed_sensor_summary(source, delta) is None
    assert fixed_sensor_text(1, 7, 7, delta).startswith("fixed sensor over the 1 window with")
    source.add_fixed_windows(np.array([3, 4, 5, 9]), delta)
    # an interval that is not window-aligned shares window 9 with the one before it
    source.set_fixed_sensor(9 * delta + delta // 2, 11 * delta + 1)
    assert fixed_sensor_summary(source, delta) == (6, 3, 11, delta)  # windows 3-5, 9-11
    fixed = "fixed sensor over the 1 window with messages (0.2 h of a 0.2 h span)"
    text = map_observation_text([fixed, fixed], source, delta)
    assert text == ("fixed sensor over the 6 windows with messages (6 of the 9 windows of 10 min "
                    "from the first to the last)")
    robot = "robot trajectory (TF map -> base_link)"
    assert map_observation_text([robot, fixed, robot], source, delta) == f"{robot} + {fixed}"


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 50_000), st.integers(0, 5_000)), min_size=1, max_size=8
    )
)
def test_the_windows_of_fixed_sensor_intervals_are_counted_once(
    intervals: list[tuple[int, int]],
) -> None:
    """Any intervals (overlapping, touching, within one window, empty): the summary counts
    each window some interval overlaps once, as a brute-force union of windows does."""
    from aion_cli.engine.observation import ObservationSource
    from aion_cli.fixed_sensor import fixed_sensor_summary

    delta = 600
    source = ObservationSource()
    windows: set[int] = set()
    for start, length in intervals:
        source.set_fixed_sensor(start, start + length)
        if length:
            windows.update(range(start // delta, (start + length - 1) // delta + 1))
    summary = fixed_sensor_summary(source, delta)
    if not windows:
        assert summary is None
        return
    assert summary == (len(windows), min(windows), max(windows), delta)


def test_parts_built_with_observed_spans_merge_into_one_build_of_their_logs(
    tmp_path: Path,
) -> None:
    """One build with ``--observed`` counts the declared time between its logs as observed
    and empty (Monday 09:00 to Tuesday 08:00: 23 h, 138 windows), and the span's time before
    its first log (Monday 00:00 to 08:00: 48 windows). Part maps keep their spans (manifest
    ``observed_spans``), so their merge fills that time too and equals the build; it said
    the merge could not, and the merged map held 138 observed windows fewer (then 48 fewer,
    the first part's time before its logs, when a build began to count it)."""
    logs = []
    for day in (0, 1):
        path = tmp_path / f"fixed{day}.mcap"
        write_office_log(path, tf=False, shift_s=day * 24 * HOUR_S, duration_s=HOUR_S)
        logs.append(path)
    declared = ("--observed", "2026-11-23 00:00..2026-11-25 00:00")
    parts = _each_built(tmp_path, logs, "p", "--part", *declared)
    report = json.loads(run("merge", *parts, "-o", tmp_path / "m.aion", "--format", "json").stdout)
    assert not [n for n in report["notes"] if "--observed" in n]
    one = tmp_path / "one.aion"
    assert run("build", *logs, "-o", one, "--workers", "1", "-q", *declared).exit_code == 0
    whole, merged = load_map(one), load_map(tmp_path / "m.aion")
    assert differences(whole.state, merged.state) == []
    assert merged.manifest["counts"] == whole.manifest["counts"]
    # both start at the span's start, 00:00 (the merge had started at the first log's 08:00)
    assert merged.manifest["time_span"]["start_ns"] == whole.manifest["time_span"]["start_ns"]
    assert whole.manifest["time_span"]["start_ns"] == 1795392000 * 10**9
    # the later part built without --observed: one build given the earlier part's span
    # counts the time between and after the logs by it, and so does the merge (it filled
    # from the later part's own spans only, found none, and said 138 windows were lost)
    assert run("build", logs[1], "--part", "-o", parts[1], "-q").exit_code == 0
    report = json.loads(run("merge", *parts, "-o", tmp_path / "m.aion", "--format", "json").stdout)
    assert not [n for n in report["notes"] if "--observed" in n]
    merged = load_map(tmp_path / "m.aion")
    assert differences(whole.state, merged.state) == []
    assert merged.manifest["counts"] == whole.manifest["counts"]
    assert merged.manifest["time_span"] == whole.manifest["time_span"]


def test_parts_declaring_their_own_spans_merge_into_one_build_given_every_span(
    tmp_path: Path,
) -> None:
    """Each part declares its own morning: Monday 05:00-12:00 and Tuesday 06:00-12:00 (logs
    08:00-09:00 each day). One build given both spans observes Monday 05:00-12:00 (42
    windows: its span reaches past its log into the time before Tuesday's) and Tuesday
    06:00-12:00 (36: to the span's end, past the last log): 78 windows, and ends at 12:00
    on Tuesday. The merge filled the time between the parts from the later part's spans
    alone and so lost Monday 09:00-12:00 (18 windows); it fills it from every part's spans,
    as the build is given them, and the time after the last part to the spans' end, as the
    build does. So does a part continued with the later log and its span."""
    logs = []
    for day in (0, 1):
        path = tmp_path / f"fixed{day}.mcap"
        write_office_log(path, tf=False, shift_s=day * 24 * HOUR_S, duration_s=HOUR_S)
        logs.append(path)
    spans = [("--observed", "2026-11-23 05:00..2026-11-23 12:00"),
             ("--observed", "2026-11-24 06:00..2026-11-24 12:00")]
    parts = []
    for k, log in enumerate(logs):
        parts.append(tmp_path / f"p{k}.aion")
        assert run("build", log, "--part", "-o", parts[k], "-q", *spans[k]).exit_code == 0
    report = json.loads(run("merge", *parts, "-o", tmp_path / "m.aion", "--format", "json").stdout)
    assert not [n for n in report["notes"] if "--observed" in n]
    one = tmp_path / "one.aion"
    both = [*spans[0], *spans[1]]
    assert run("build", *logs, "-o", one, "--workers", "1", "-q", *both).exit_code == 0
    whole, merged = load_map(one), load_map(tmp_path / "m.aion")
    assert whole.manifest["counts"]["windows"] == 78
    assert merged.manifest["counts"] == whole.manifest["counts"]
    assert differences(whole.state, merged.state) == []
    assert merged.manifest["time_span"] == whole.manifest["time_span"]
    assert whole.manifest["time_span"]["start_ns"] == (1795392000 + 5 * HOUR_S) * 10**9
    assert whole.manifest["time_span"]["end_ns"] == (1795392000 + 36 * HOUR_S) * 10**9 - 1
    # the first part continued with the second log and its span, then merged alone: the
    # continuation fills with the part's stored span too (it had filled with its own, 60)
    r = run("build", logs[1], "--part", "--map", parts[0], "-q", *spans[1])
    assert r.exit_code == 0, r.stderr
    assert run("merge", parts[0], "-o", tmp_path / "c.aion", "-q").exit_code == 0
    continued = load_map(tmp_path / "c.aion")
    assert continued.manifest["counts"] == whole.manifest["counts"]
    assert differences(whole.state, continued.state) == []
    assert continued.manifest["time_span"] == whole.manifest["time_span"]


def test_a_fixed_sensor_is_described_in_windows_and_old_manifests_still_parse() -> None:
    """The description counts windows (it gave their time as the log's: a 250-second log read
    "(10 min of a 10 min span)"), the window's length in minutes, seconds or hours. The share
    read back from a manifest is the windows' share, from this text and from the texts in
    times that maps were written with before (hours, minutes)."""
    from aion_cli.fixed_sensor import fixed_sensor_share, fixed_sensor_text

    minute = 60 * 10**9
    short = fixed_sensor_text(2, 0, 1, 10 * minute)
    assert short.endswith("(2 of the 2 windows of 10 min from the first to the last)")
    assert fixed_sensor_text(1, 0, 2, minute // 2).endswith("(1 of the 3 windows of 30 s from "
                                                            "the first to the last)")
    assert fixed_sensor_text(2, 0, 9, 60 * minute).endswith("(2 of the 10 windows of 1.0 h from "
                                                            "the first to the last)")
    assert fixed_sensor_share(short) == 1.0
    long = fixed_sensor_text(4, 0, 145, 10 * minute)
    assert long.endswith("(4 of the 146 windows of 10 min from the first to the last)")
    assert fixed_sensor_share(long) == pytest.approx(4 / 146)
    assert fixed_sensor_share(long, recording_windows=8) == 0.5
    for old in ("fixed sensor over the 2 windows with messages (0.3 h of a 0.6 h span)",
                "fixed sensor over the 2 windows with messages (20 min of a 40 min span)"):
        assert fixed_sensor_share(old) == 0.5
        assert fixed_sensor_share(old, recording_windows=8) == 0.25


def test_parts_merged_in_two_steps_say_how_to_merge_them_exactly(tmp_path: Path) -> None:
    """merge(P0, merge(P1, P2)) is not merge(P0, P1, P2): the inner merge is an ordinary map
    whose days were scored without P0's. The note of approximation 2 said only that scores
    add; it now says to merge the parts in one merge, which is exact."""
    logs = _logs(tmp_path, [0, 1, 2])
    parts = _each_built(tmp_path, logs, "p", "--part")
    inner, outer, once = (tmp_path / f"{n}.aion" for n in ("inner", "outer", "once"))
    assert run("merge", parts[1], parts[2], "-o", inner, "-q").exit_code == 0
    result = run("merge", parts[0], inner, "-o", outer, "--format", "json")
    notes = [n for n in json.loads(result.stdout)["notes"] if "approximation 2" in n]
    assert len(notes) == 1
    assert "merge part maps only, all in one merge" in notes[0]
    assert run("merge", *parts, "-o", once, "-q").exit_code == 0
    assert differences(_state(outer), _state(once)) != []  # type: ignore[arg-type]
    whole = tmp_path / "whole.aion"
    assert run("build", *logs, "-o", whole, "--workers", "1", "-q").exit_code == 0
    assert differences(_state(whole), _state(once)) == []  # type: ignore[arg-type]
    # ordinary maps only: no part map to point to
    maps = _each_built(tmp_path, logs, "m")
    result = run("merge", *maps, "-o", tmp_path / "ord.aion", "--format", "json")
    assert not [n for n in json.loads(result.stdout)["notes"] if "part maps" in n]


def test_an_ordinary_map_after_observed_spans_says_only_the_declared_time_it_loses(
    tmp_path: Path,
) -> None:
    """Each ordinary map built with the two days' span observes it whole (to its end, as a
    log converted with it does), so the two maps overlap, and the merge says a window both
    observed counts twice. Built with spans that end at its log's end, an ordinary map's
    spans cover no time between it and the next map: one build given the same spans counts
    none of it, and the merge equals it; the note had counted the 138 windows between the
    logs (Monday 09:00 to Tuesday 08:00) as lost all the same, as it did for a first map whose
    span ended at 20:00 (72, Monday 20:00 to Tuesday 08:00, though no span covers them). A
    part map keeps its spans: an ordinary map after it, which the merge does not fill before,
    is said to lose the windows between them the part's spans cover (66 to 20:00)."""
    logs, maps = [], []
    declared = ("--observed", "2026-11-23 00:00..2026-11-25 00:00")
    for day in (0, 1):
        path = tmp_path / f"fixed{day}.mcap"
        write_office_log(path, tf=False, shift_s=day * 24 * HOUR_S, duration_s=HOUR_S)
        logs.append(path)
        one = tmp_path / f"m{day}.aion"
        assert run("build", path, "-o", one, "-q", *declared).exit_code == 0
        maps.append(one)
    report = json.loads(run("merge", *maps, "-o", tmp_path / "m.aion", "--format", "json").stdout)
    assert [n for n in report["notes"] if n.startswith("the times of m0.aion and m1.aion "
                                                        "overlap")]
    one = tmp_path / "one.aion"
    for end in ("09:00", "20:00"):  # to its log's end, and past it
        first = ("--observed", f"2026-11-23 00:00..2026-11-23 {end}")
        assert run("build", logs[0], "-o", maps[0], "-q", *first).exit_code == 0
        assert run("build", logs[1], "-o", maps[1], "-q").exit_code == 0
        merged = tmp_path / "m.aion"
        report = json.loads(run("merge", *maps, "-o", merged, "--format", "json").stdout)
        assert not [n for n in report["notes"] if "--observed" in n]
        assert run("build", *logs, "-o", one, "--workers", "1", "-q", *first).exit_code == 0
        whole = load_map(one)
        assert load_map(merged).manifest["counts"]["windows"] == whole.manifest["counts"]["windows"]
        assert differences(whole.state, load_map(merged).state) == []
    # the first log a part built with the span to 20:00: its spans are stored
    part = tmp_path / "p0.aion"
    assert run("build", logs[0], "--part", "-o", part, "-q", *first).exit_code == 0
    report = json.loads(run("merge", part, maps[1], "-o", merged, "--format", "json").stdout)
    gap = [n for n in report["notes"] if "--observed" in n]
    assert len(gap) == 1
    assert "m1.aion was merged, but not exactly" in gap[0]
    assert "the 66 window(s) between its logs and those before it" in gap[0]
    assert "--part --observed" in gap[0]
    lost = load_map(merged)
    assert differences(whole.state, lost.state)
    assert lost.manifest["counts"]["windows"] == whole.manifest["counts"]["windows"] - 66
