"""``aion merge`` of a fleet's maps: every robot writes its map under the same file name in
a folder of its own (robot1/map.aion, robot2/map.aion), so the merge's messages name such
maps by the path given, not by a file name that all of them share."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.engine.mapper import Mapper
from aion_cli.errors import ConfigError, MapFileError
from aion_cli.merging import merge_map_files
from tests.engine.engine_builders import T0
from tests.engine.state_logs import CFG, DAY, W, fixed_sensor_log, run_steps
from tests.merging_logs import fixed_sensor_map, log_span, save_map


def _robot(folder: Path, name: str, start: int, seed: int, mapper: Mapper | None = None) -> Path:
    path = folder / name / "map.aion"
    path.parent.mkdir()
    if mapper is None:
        return fixed_sensor_map(path, (f"{name}.mcap",), start, seed)
    state = run_steps(fixed_sensor_log(start, seed=seed), mapper).state
    return save_map(state, path, (f"{name}.mcap",), log_span(start))


def test_a_refusal_names_maps_of_one_file_name_by_their_paths(tmp_path: Path) -> None:
    one = _robot(tmp_path, "robot1", T0, 1)
    two = _robot(tmp_path, "robot2", T0 + 2 * DAY, 2, Mapper(CFG.replace(cell_size=0.25)))
    with pytest.raises(ConfigError) as exc:
        merge_map_files([one, two], tmp_path / "fleet.aion")
    # before: "cannot merge map.aion and map.aion: ..."
    assert f"cannot merge {one} and {two}:" in exc.value.message
    assert "cell_size 0.5 vs 0.25" in exc.value.message


def test_notes_name_maps_of_one_file_name_by_their_paths(tmp_path: Path) -> None:
    one = _robot(tmp_path, "robot1", T0, 1)
    two = _robot(tmp_path, "robot2", T0 + 3 * W, 2)  # starts before robot1's map ends
    other = fixed_sensor_map(tmp_path / "day3.aion", ("day3.mcap",), T0 + 2 * DAY, 3)
    report = merge_map_files([one, two, other], tmp_path / "fleet.aion")
    overlap = next(n for n in report.notes if "overlap or interleave" in n)
    assert overlap.startswith(f"the times of {one} and {two} overlap"), overlap
    assert report.graph_source == "day3.aion's latest graph"  # a name no other input has
    assert [i.file.path for i in report.inputs] == [str(p.resolve()) for p in (one, two, other)]


def test_the_closing_table_lists_maps_of_one_file_name_by_their_paths(tmp_path: Path) -> None:
    from tests.cli.conftest import run

    one = _robot(tmp_path, "robot1", T0, 1)
    two = _robot(tmp_path, "robot2", T0 + 2 * DAY, 2)
    done = run("merge", one, two, "-o", tmp_path / "fleet.aion")
    assert done.exit_code == 0, done.stderr
    rows = [line for line in done.stderr.splitlines() if " input " in line]
    # before: two rows "input map.aion", which told nobody which robot had what
    assert [str(p) in row for row, p in zip(rows, (one, two), strict=True)] == [True, True]


def test_info_lists_the_maps_a_merged_map_came_from(tmp_path: Path) -> None:
    """``aion info`` of a merged map showed its logs but not the maps it was merged from nor
    the lineage (only --format json had them); now a row per map (by path when file names
    are shared) with the map file's own sha256, and the lineage."""
    import hashlib

    from tests.cli.conftest import run_process

    one = _robot(tmp_path, "robot1", T0, 1)
    two = _robot(tmp_path, "robot2", T0 + 2 * DAY, 2)
    three = fixed_sensor_map(tmp_path / "day5.aion", ("day5.mcap",), T0 + 4 * DAY, 3)
    out = tmp_path / "fleet.aion"
    merge_map_files([one, two, three], out)
    done = run_process("info", out)
    assert done.returncode == 0, done.stderr
    rows = [line for line in done.stdout.splitlines() if "merged map" in line]
    for row, path in zip(rows, (one, two, three), strict=True):
        digest = hashlib.sha256(path.read_bytes()).hexdigest()[:12]
        shown = str(path.resolve()) if path.name == "map.aion" else path.name
        assert f" {shown}  " in row, row
        assert f"sha256 {digest}" in row, row
    cells = [[c.strip() for c in line.split("│")[1:3]] for line in done.stdout.splitlines()]
    assert ["merged from", "3 maps by aion merge (one scene-graph session: nodes joined by id)"
            ] in cells


def test_maps_of_another_zone_are_refused_naming_the_zones(tmp_path: Path) -> None:
    """A map built with --tz Europe/Berlin beside one in UTC: its config differs in the zone
    and in the FreMEn clock UTC does not record. The refusal said 'different model
    parameters (fremen_clock None vs 'standard', timezone 'UTC' vs 'Europe/Berlin')' with a
    hint about --config files; it names the zones and --tz."""
    one = fixed_sensor_map(tmp_path / "utc.aion", ("utc.mcap",), T0, 1)
    berlin = CFG.replace(timezone="Europe/Berlin")
    state = run_steps(fixed_sensor_log(T0 + 2 * DAY, seed=2), Mapper(berlin)).state
    assert state.config.to_dict()["fremen_clock"] != one_clock(one)  # as aion build writes
    two = save_map(state, tmp_path / "berlin.aion", ("berlin.mcap",),
                   log_span(T0 + 2 * DAY), timezone="Europe/Berlin")
    with pytest.raises(ConfigError) as exc:
        merge_map_files([one, two], tmp_path / "out.aion")
    assert exc.value.message == (
        "cannot merge utc.aion (UTC) and berlin.aion (Europe/Berlin): their days follow "
        "different time zones"
    )
    assert exc.value.hint == "rebuild one of them with the other's --tz"


def one_clock(path: Path) -> object:
    from aion_cli.formats.mapfile import read_manifest

    return read_manifest(path)["config"].get("fremen_clock")


def test_a_map_this_aion_cannot_read_is_named(tmp_path: Path) -> None:
    """Of the maps of a merge, one written by a newer aion (format 3.0) or an older one
    (state version 1): the error said 'map format 3.0 is newer than this aion supports'
    without saying which map; it starts with the map's path."""
    from aion_cli.errors import MapVersionError
    from tests.robustness.conftest import rewrite_map

    one = _robot(tmp_path, "robot1", T0, 1)
    two = _robot(tmp_path, "robot2", T0 + 2 * DAY, 2)
    newer = rewrite_map(two, tmp_path / "newer.aion",
                        manifest_edit=lambda m: m.update(version="3.0"))
    with pytest.raises(MapVersionError) as exc:
        merge_map_files([one, newer], tmp_path / "out.aion")
    assert exc.value.message.startswith(f"{newer}: map format 3.0 is newer"), exc.value.message

    def first_state(manifest: dict[str, object]) -> None:
        manifest["state"]["state_version"] = 1  # type: ignore[index]

    older = rewrite_map(two, tmp_path / "older.aion", manifest_edit=first_state)
    with pytest.raises(MapFileError) as failed:
        merge_map_files([one, older], tmp_path / "out.aion")
    assert failed.value.message.startswith(f"{older}: "), failed.value.message
    assert "state version 1" in failed.value.message
    assert not (tmp_path / "out.aion").exists()


def test_one_recording_in_two_log_files_is_refused(tmp_path: Path) -> None:
    """The same recording converted to another container has another sha256, so the log
    check let the maps of both files through, and the merge counted every person twice with
    a note that their times overlap. Such maps hold the same entries over the same span."""
    from tests.cli.conftest import assert_one_line_error, run

    one = fixed_sensor_map(tmp_path / "day.aion", ("day.mcap",), T0, 1)
    copy = fixed_sensor_map(tmp_path / "day_bag.aion", ("day.bag",), T0, 1)
    later = fixed_sensor_map(tmp_path / "day3.aion", ("day3.mcap",), T0 + 2 * DAY, 3)
    out = tmp_path / "out.aion"
    done = run("merge", one, later, copy, "-o", out)
    assert done.exit_code == 2, done.stderr
    assert_one_line_error(
        done.stderr, "day.aion (day.mcap) and day_bag.aion (day.bag) hold the same detections"
    )
    assert "hint: merge one of the two maps" in done.stderr
    assert not out.exists()


def test_maps_of_one_time_with_other_people_merge(tmp_path: Path) -> None:
    """Two sensors over the same span that saw other people (a fleet at work at once) are
    not one recording: they merge, each map's detections counted once."""
    one = fixed_sensor_map(tmp_path / "left.aion", ("left.mcap",), T0, 1)
    two = fixed_sensor_map(tmp_path / "right.aion", ("right.mcap",), T0, 2)
    report = merge_map_files([one, two], tmp_path / "out.aion")
    expected = sum(
        run_steps(fixed_sensor_log(T0, seed=s)).state.accepted for s in (1, 2)
    )
    assert report.detections == expected
    assert any("overlap or interleave" in n for n in report.notes)


def test_maps_without_detections_are_not_taken_for_one_recording(tmp_path: Path) -> None:
    """Two robots that saw nobody along one route over one span hold the same (empty)
    entries; that does not make them one recording."""
    import numpy as np

    from tests.engine.engine_builders import graph
    from tests.engine.state_logs import NODES

    def empty(name: str) -> Path:
        steps = [
            lambda m: m.set_fixed_sensor(T0, T0 + 6 * W),
            lambda m: m.add_graph(graph(T0, list(range(5)), np.array(NODES))),
        ]
        state = run_steps(steps, Mapper(CFG)).state
        assert state.accepted == 0
        return save_map(state, tmp_path / f"{name}.aion", (f"{name}.mcap",), log_span(T0))

    report = merge_map_files([empty("a"), empty("b")], tmp_path / "out.aion")
    assert report.detections == 0


def _zoned(path: Path, start: int, seed: int, zone: str) -> Path:
    """A fixed sensor's map built and saved in ``zone`` (spelt as given, as --tz writes it)."""
    state = run_steps(fixed_sensor_log(start, seed=seed), Mapper(CFG.replace(timezone=zone))).state
    assert state.config.timezone == zone
    return save_map(state, path, (path.with_suffix(".mcap").name,), log_span(start), zone)


def test_two_names_of_one_zone_merge_as_that_zone(tmp_path: Path) -> None:
    """Robots set up with --tz Etc/UTC and with the default UTC, or with Asia/Calcutta and
    Asia/Kolkata (one zone, the first name a link to the second): the merge refused them as
    'their days follow different time zones'. They merge, as the maps of one spelling do,
    under the spelling of the first map given."""
    import zipfile

    from aion_cli.formats.mapfile import read_manifest

    def members(path: Path) -> dict[str, bytes]:
        with zipfile.ZipFile(path) as z:
            return {n: z.read(n) for n in z.namelist() if n != "manifest.json"}

    one = _zoned(tmp_path / "utc.aion", T0, 1, "UTC")
    same = _zoned(tmp_path / "later_utc.aion", T0 + 2 * DAY, 2, "UTC")
    etc = _zoned(tmp_path / "later_etc.aion", T0 + 2 * DAY, 2, "Etc/UTC")
    merge_map_files([one, same], tmp_path / "ref.aion")
    merge_map_files([one, etc], tmp_path / "etc.aion")
    assert members(tmp_path / "etc.aion") == members(tmp_path / "ref.aion")
    for given, zone in (([one, etc], "UTC"), ([etc, one], "Etc/UTC")):
        merge_map_files(given, tmp_path / "out.aion")
        manifest = read_manifest(tmp_path / "out.aion")
        assert (manifest["timezone"], manifest["config"]["timezone"]) == (zone, zone)
    kolkata = _zoned(tmp_path / "kolkata.aion", T0, 1, "Asia/Kolkata")
    calcutta = _zoned(tmp_path / "calcutta.aion", T0 + 2 * DAY, 2, "Asia/Calcutta")
    merge_map_files([calcutta, kolkata], tmp_path / "india.aion")
    manifest = read_manifest(tmp_path / "india.aion")
    assert (manifest["timezone"], manifest["config"]["timezone"]) == ("Asia/Calcutta",) * 2


def test_zones_that_only_look_alike_are_still_refused(tmp_path: Path) -> None:
    """Europe/Berlin and Europe/Paris keep one clock today but not in their history: two
    zones, refused as before."""
    from aion_cli.engine.temporal.zones import same_zone

    assert same_zone("US/Eastern", "America/New_York")
    assert same_zone("+00:00", "Etc/UTC")
    assert not same_zone("Europe/Berlin", "Europe/Paris")
    assert not same_zone("UTC", "+01:00")
    berlin = _zoned(tmp_path / "berlin.aion", T0, 1, "Europe/Berlin")
    paris = _zoned(tmp_path / "paris.aion", T0 + 2 * DAY, 2, "Europe/Paris")
    with pytest.raises(ConfigError, match="different time zones"):
        merge_map_files([berlin, paris], tmp_path / "out.aion")


def test_maps_that_plan_with_other_parameters_merge_with_a_note(tmp_path: Path) -> None:
    """A robot whose map was built with another plan_speed or planner weight (read by aion
    plan only, never by a build) was refused with 'rebuild one of them'. Its counts are
    those of the default config: the maps merge, the merged map plans as the first given,
    and a note names the values left behind."""
    import zipfile

    from aion_cli.formats.mapfile import read_manifest

    def members(path: Path) -> dict[str, bytes]:
        with zipfile.ZipFile(path) as z:
            return {n: z.read(n) for n in z.namelist() if n != "manifest.json"}

    planner = CFG.replace(plan_speed=1.5, plan_w_flow=2.0)
    one = _robot(tmp_path, "robot1", T0, 1)
    two = _robot(tmp_path, "robot2", T0 + 2 * DAY, 2, Mapper(planner))
    default = _robot(tmp_path, "robot3", T0 + 2 * DAY, 2)
    ref = merge_map_files([one, default], tmp_path / "ref.aion")
    assert not any("plan" in n for n in ref.notes)
    report = merge_map_files([one, two], tmp_path / "fleet.aion")
    assert members(tmp_path / "fleet.aion") == members(tmp_path / "ref.aion")
    assert read_manifest(tmp_path / "fleet.aion")["config"]["plan_speed"] == 1.0
    note = next(n for n in report.notes if n.startswith("the maps plan with different"))
    assert f"plan_speed 1.0 in {one}, 1.5 in {two}" in note
    assert f"plan_w_flow 1.0 in {one}, 2.0 in {two}" in note
    merge_map_files([two, one], tmp_path / "reversed.aion")
    assert read_manifest(tmp_path / "reversed.aion")["config"]["plan_speed"] == 1.5
    wider = _robot(tmp_path, "robot4", T0 + 2 * DAY, 2, Mapper(planner.replace(cell_size=0.25)))
    with pytest.raises(ConfigError) as exc:
        merge_map_files([one, wider], tmp_path / "out.aion")
    assert "(cell_size 0.5 vs 0.25)" in exc.value.message  # the model, not the planner
