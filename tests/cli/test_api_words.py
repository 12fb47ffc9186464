"""Errors raised through the Python API name its keywords, not the command line's options:
``aion.build(logs, detection_topics=["/nope"])`` was told ``use one of: --detections-topic
/spencer/...``, a flag a script cannot pass."""

from __future__ import annotations

from pathlib import Path

import pytest

import aion_cli as aion
from aion_cli.api_words import api_text
from aion_cli.errors import AionError
from tests.cli.conftest import Office, run

OPTIONS = ("--detections-topic", "--graph-topic", "--map-frame", "--nav-layer")


@pytest.mark.parametrize(
    ("keywords", "option", "said"),
    [
        ({"detection_topics": ["/nope"]}, "--detections-topic", 'detection_topics="/'),
        ({"graph_topic": "/nope"}, "--graph-topic", 'graph_topic="/'),
        ({"map_frame": "nope"}, "--map-frame", 'map_frame="map"'),
        ({"nav_layer": "9"}, "--nav-layer", "with nav_layer="),
    ],
)
def test_a_build_error_names_the_keyword_the_command_names_the_option(
    office: Office, tmp_path: Path, keywords: dict[str, object], option: str, said: str
) -> None:
    with pytest.raises(AionError) as caught:
        aion.build(office.log, tmp_path / "x.aion", **keywords)  # type: ignore[arg-type]
    text = f"{caught.value} {caught.value.hint}"
    assert said in text
    assert not any(o in text for o in OPTIONS), text
    # the command line keeps its own words for the same mistake
    value = next(iter(keywords.values()))
    given = value[0] if isinstance(value, list) else value
    result = run("build", office.log, "-o", tmp_path / "y.aion", option, str(given))
    assert result.exit_code == 2
    assert option in result.stderr


def test_the_rewrite_takes_values_placeholders_and_bare_options() -> None:
    assert api_text("use one of: --detections-topic /a, --detections-topic /b") == (
        'use one of: detection_topics="/a", detection_topics="/b"'
    )
    assert api_text("--nav-layer NOPE chooses the layer of a --graph FILE") == (
        'nav_layer="NOPE" chooses the layer of a graph=FILE'
    )
    assert api_text("give a key with --nav-layer; or --tz=Europe/Berlin") == (
        'give a key with nav_layer=; or tz="Europe/Berlin"'
    )
    # an option the API has no keyword for, and a rewritten text, are left as they are
    assert api_text("--graph-period 10s and --workers 2") == 'graph_period="10s" and workers=2'
    assert api_text("--print-config or --suggest-mapping") == "--print-config or --suggest-mapping"
    once = api_text("--map-frame odom")
    assert api_text(once) == once == 'map_frame="odom"'


def test_the_observed_ignored_warning_names_the_keyword_in_the_api_and_the_option_on_the_cli(
    tmp_path: Path,
) -> None:
    """Declared spans beside a robot's trajectory are ignored, with a warning. Through the API
    it said "--observed ignored: ...", a flag a script cannot pass; it now says
    "observed= ignored: ..." (the AionWarning and the report's list alike), and the command
    line still says --observed."""
    from tests.cli.logdata import write_office_log

    log = tmp_path / "office.mcap"
    write_office_log(log)  # TF map -> base_link
    span = ("2026-11-23 07:00", "2026-11-23 10:00")
    with pytest.warns(aion.AionWarning) as caught:
        built = aion.build(log, tmp_path / "api.aion", observed=[span])
    said = [str(w.message) for w in caught if "ignored" in str(w.message)]
    assert said == ["observed= ignored: the logs have a robot trajectory (tf map->base_link), "
                    "whose poses say which places the sensor saw in each window"]
    assert said[0] in built.report.warnings
    assert not [w for w in built.report.warnings if "--observed" in w]
    result = run("build", log, "-o", tmp_path / "cli.aion", "--observed", "..".join(span))
    assert result.exit_code == 0
    assert "warning: --observed ignored: the logs have a robot trajectory" in result.stderr


def test_a_word_after_an_option_that_goes_on_with_the_sentence_is_not_its_value() -> None:
    """'--nav-layer ignored: ...' read 'nav_layer="ignored:" ...' and 'as --map-frame said'
    read 'as map_frame="said"'."""
    assert api_text("--nav-layer ignored: no scene graph") == "nav_layer= ignored: no scene graph"
    assert api_text("as --map-frame said so; --tz or the config") == (
        "as map_frame= said so; tz= or the config"
    )
    assert api_text("--observed ignored: a robot") == "observed= ignored: a robot"


def test_build_errors_name_the_part_config_and_continue_keywords(
    office: Office, tmp_path: Path
) -> None:
    """aion.build(..., part=True, continue_from=MAP) said "--part cannot continue an ordinary
    map" and a config different from the continued map's "--config differs from ...": options
    the API has keywords for (part, config, continue_from, workers, scheduler, derive_graph)
    were left as flags. The command line keeps them."""
    from tests.cli.logdata import write_office_log

    later = tmp_path / "later.mcap"
    write_office_log(later, shift_s=86_400)  # the next day: a log the map does not hold
    with pytest.raises(AionError) as caught:
        aion.build(later, tmp_path / "p.aion", part=True, continue_from=office.map)
    assert caught.value.message == "part=True cannot continue an ordinary map"
    # the command it suggests is said as the call that does the same
    assert caught.value.hint == (
        'build the part into a new file (aion.build(LOG, "PART.aion", part=True))'
    )
    with pytest.raises(AionError) as caught:
        aion.build(later, tmp_path / "c.aion", continue_from=office.map, config={"bins": 16})
    assert caught.value.message.startswith("config= differs from the config the map was built")
    result = run("build", later, "-o", tmp_path / "q.aion", "--part", "--map", office.map)
    assert result.exit_code == 2
    assert "error: --part cannot continue an ordinary map" in result.stderr
    assert "hint: build the part into a new file (aion build LOG --part -o PART.aion)" in (
        result.stderr
    )


def test_a_command_line_the_api_has_a_call_for_is_said_as_the_call() -> None:
    """A fixed sensor's warning ends "declare the spans it was recording with aion build
    --observed"; through the API it read "... with aion build observed=" (neither a command nor
    Python), then the command whole: a shell command a script's author must translate. A
    quoted ``aion build`` / ``aion merge`` line is now the call that does the same, and a
    command the API has no call for (``aion info``) keeps its options; the sentence around
    it still speaks keywords."""
    from aion_cli.fixed_sensor import SILENT_HINT

    assert SILENT_HINT.endswith("with aion build --observed")
    assert api_text(SILENT_HINT).endswith("with aion.build(..., observed=[...])")
    assert api_text(
        "rebuild with --nav-layer naming that layer (e.g. --nav-layer PLACES); "
        "`aion info GRAPH_FILE --nav-layer PLACES` shows how many"
    ) == (
        'rebuild with nav_layer= naming that layer (e.g. nav_layer="PLACES"); '
        "`aion info GRAPH_FILE --nav-layer PLACES` shows how many"
    )
    assert api_text("(aion build LOG --map PART.aion --observed ...); or --map A.aion") == (
        '(aion.build(LOG, continue_from="PART.aion", observed=[...])); '
        'or continue_from="A.aion"'
    )


@pytest.mark.parametrize(
    ("command", "call"),
    [
        ("(aion build LOG1 LOG2 --part -o PART.aion)",
         '(aion.build([LOG1, LOG2], "PART.aion", part=True))'),
        ("(one part map, aion build --part, alone)",
         "(one part map, aion.build(..., part=True), alone)"),
        ("build one with `aion build LOG`", "build one with `aion.build(LOG)`"),
        ("(aion build FIRST.mcap -o MAP.aion, then aion build NEXT.mcap --map MAP.aion)",
         '(aion.build("FIRST.mcap", "MAP.aion"), '
         'then aion.build("NEXT.mcap", continue_from="MAP.aion"))'),
        ("(aion build a.mcap b.mcap -o NEW.aion)",
         '(aion.build(["a.mcap", "b.mcap"], "NEW.aion"))'),
        ("(aion merge PART.aion -o MAP.aion)", '(aion.merge(["PART.aion"], "MAP.aion"))'),
        # a usage line's optional paths: more paths of the call's list
        ("aion merge PART.aion [PART2.aion ...] -o MAP.aion scores its days into a map",
         'aion.merge(["PART.aion", "PART2.aion", ...], "MAP.aion") scores its days into a map'),
        ("(aion build LOG [LOG2] -o MAP.aion)", '(aion.build([LOG, LOG2], "MAP.aion"))'),
        ("continue it (aion build --map) with",
         "continue it (aion.build(..., continue_from=MAP)) with"),
        ("(aion info MAP shows it; aion build --config FILE)",
         "(aion info MAP shows it; aion.build(..., config=CONFIG))"),
        # a command alone, the sentence going on: the function's name
        ("aion merge fills them as it joins the parts",
         "aion.merge fills them as it joins the parts"),
        ("; aion build drops them (docs)", "; aion.build drops them (docs)"),
        ("query it with `aion predict x.aion`",
         'query it with `aion.Map.load("x.aion").predict()`'),
        ("(aion predict MAP --layer rooms --top 5)",
         '(aion.Map.load(MAP).predict(layer="rooms", top=5))'),
        # no call for the command, or no keyword for an option: the command line, whole
        ("`aion build --print-config` prints", "`aion build --print-config` prints"),
        ("the table alone: aion predict MAP --time T --format csv > FILE.csv",
         "the table alone: aion predict MAP --time T --format csv > FILE.csv"),
    ],
)  # fmt: skip
def test_quoted_commands_as_calls(command: str, call: str) -> None:
    assert api_text(command) == call
    assert api_text(call) == call  # said once: a second pass changes nothing


def test_merge_and_part_errors_name_the_calls_the_cli_its_commands(
    office: Office, tmp_path: Path
) -> None:
    """A merge of one ordinary map said "(one part map, aion build --part, alone is made a
    map)" to a script; it says ``aion.build(..., part=True)``, the command line still
    ``aion build --part``."""
    with pytest.raises(AionError) as caught:
        aion.merge([office.map], tmp_path / "m.aion")
    assert "(one part map, aion.build(..., part=True), alone is made a map)" in str(caught.value)
    result = run("merge", office.map, "-o", tmp_path / "n.aion")
    assert result.exit_code == 2
    assert "(one part map, aion build --part, alone is made a map)" in result.stderr


def test_flags_numbers_and_values_ending_a_clause() -> None:
    assert api_text("try --graph FILE or --derive-graph)") == "try graph=FILE or derive_graph=True)"
    assert api_text("rerun with --workers 1; --workers N") == "rerun with workers=1; workers=N"
    assert api_text("--workers ignored: one log") == "workers= ignored: one log"
    assert api_text("--scheduler tcp://10.0.0.5:8786: not contacted") == (
        'scheduler="tcp://10.0.0.5:8786": not contacted'
    )
    assert api_text("stability_s in --config), so") == "stability_s in config=), so"


def test_a_build_report_s_notes_name_keywords_too(office: Office, tmp_path: Path) -> None:
    """aion.build(log, derive_graph=True) on a log with scene graphs: ``report.notes`` said
    "--derive-graph ignored: the log has scene graphs" (its warnings were in the API's words,
    its notes were not). The command's JSON keeps the option."""
    built = aion.build(office.log, tmp_path / "d.aion", derive_graph=True)
    assert "derive_graph=True ignored: the log has scene graphs" in built.report.notes
    assert not [n for n in built.report.notes if "--" in n], built.report.notes
    cli = run("build", office.log, "-o", tmp_path / "c.aion", "--derive-graph", "--format",
              "json")
    assert "--derive-graph ignored: the log has scene graphs" in cli.stdout


def test_holdout_s_warnings_name_its_radius_keyword(office: Office, tmp_path: Path) -> None:
    """Map.holdout whose radius no test detection lies within (logs of another place or
    frame) warned "none of the ... test detections lies within 1 m (--radius) of a map
    entry": an option of aion evaluate holdout; the keyword is radius."""
    from tests.cli.logdata import write_office_log

    far = tmp_path / "far.mcap"
    write_office_log(far, shift_s=86_400)
    m = aion.Map.load(office.map)
    with pytest.warns(aion.AionWarning) as caught:
        m.holdout(far, radius=1e-9)
    said = [str(w.message) for w in caught if "lies within" in str(w.message)]
    assert said, [str(w.message) for w in caught]
    assert "(radius=)" in said[0]
    assert "--radius" not in said[0]


def test_words_that_go_on_with_a_library_sentence_are_not_values() -> None:
    """Real messages of the library read, through the API, 'pin a version with
    dsg_version="if" you know it', 'and map_frame="read" the test logs into ...' and 'see
    map_frame="/" base_frame=': the word after an option was taken for its value."""
    from aion_cli.formats.dsg_payload import __file__ as payload_source

    assert "pin a version with --dsg-version if you know it" in Path(payload_source).read_text()
    assert api_text("pin a version with --dsg-version if you know it") == (
        "pin a version with dsg_version= if you know it"
    )
    assert api_text("and --map-frame read the test logs into 'odom'") == (
        "and map_frame= read the test logs into 'odom'"
    )
    assert api_text("see --map-frame / --base-frame") == "see map_frame= / base_frame="
    assert api_text("check --map-frame / the detections' frame_id") == (
        "check map_frame= / the detections' frame_id"
    )


def test_an_export_refusing_to_replace_names_force_true_in_the_api(
    office: Office, tmp_path: Path
) -> None:
    """Map.export into a folder whose export files lost their list said "--force replaces
    it", an option Map.export takes as ``force=True``; the command line keeps ``--force``.
    Both then replace the files, as the hint says."""
    from aion_cli.export_stale import MANIFEST

    m = aion.Map.load(office.map)
    folder = tmp_path / "out"
    m.export(folder, time="2026-11-23 08:30")
    (folder / MANIFEST).unlink()
    with pytest.raises(AionError) as caught:
        m.export(folder, time="2026-11-23 08:30")
    assert caught.value.hint == "force=True replaces it; or export into another folder"
    assert m.export(folder, time="2026-11-23 08:30", force=True)
    (folder / MANIFEST).unlink()
    cli = ("export", office.map, "--time", "2026-11-23 08:30", "-o", folder)
    result = run(*cli)
    assert result.exit_code == 2
    assert "hint: --force replaces it; or export into another folder" in result.stderr
    assert run(*cli, "--force").exit_code == 0


def test_a_plan_from_a_hash_cell_hints_the_predict_call_in_the_api(
    office: Office, tmp_path: Path
) -> None:
    """A plan from a hash cell's id hinted "(aion predict MAP --node c... shows it)" to a
    script too; the API says the call, ``aion.Map.load(MAP).predict(nodes="c...")``, the
    command line its command."""
    from aion_cli.engine.node_ids import INDEX_MASK

    cell = f"c{INDEX_MASK + 1}"
    with pytest.raises(AionError) as caught:
        aion.Map.load(office.map).plan(cell, "p1", time="2026-01-12 08:40")
    assert caught.value.hint == (
        f'give its position as x,y (aion.Map.load(MAP).predict(nodes="{cell}") shows it), a '
        "place id or a room"
    )
    result = run("plan", office.map, "--from", cell, "--to", "p1", "--time", "2026-01-12 08:40")
    assert result.exit_code == 2
    assert f"(aion predict MAP --node {cell} shows it)" in result.stderr


def test_the_sim_time_warning_names_the_predict_call_with_its_quoted_time() -> None:
    """A log on a simulation's clock is warned "query it at times of its own (aion predict MAP
    --time "1970-01-05 08:00")"; in the API's words the quoted time, spaces and all, is the
    ``time`` of the call, and an unclosed quote leaves the command whole."""
    from aion_cli.stamp_warnings import sim_time_warning

    text = sim_time_warning(4 * 86_400 * 10**9 + 3600 * 10**9)  # Monday 1970-01-05 01:00
    assert text is not None
    assert '(aion predict MAP --time "1970-01-05 08:00")' in text
    assert '(aion.Map.load(MAP).predict(time="1970-01-05 08:00"))' in api_text(text)
    assert api_text('aion predict MAP --time "08:00') == 'aion predict MAP --time "08:00'


def test_a_command_with_an_option_the_api_cannot_say_stays_whole() -> None:
    assert api_text("(aion build LOG -o)") == "(aion build LOG -o)"
    assert api_text("(aion build LOG --part -x y)") == "(aion build LOG --part -x y)"


def test_a_part_map_s_query_hint_is_the_merge_call_with_every_part(
    office: Office, tmp_path: Path
) -> None:
    """A part map's query is refused with the hint ``aion merge PART.aion [PART2.aion ...] -o
    MAP.aion``; through the API it read ``aion.merge(["PART.aion", "[PART2.aion", "...]"],
    "MAP.aion")``, the usage line's brackets quoted into file names. The optional parts are
    more items of the call's list now; the command line keeps its usage line."""
    part = aion.build(office.log, tmp_path / "p.aion", part=True)
    with pytest.raises(AionError) as caught:
        part.predict(historical=True)
    assert caught.value.hint == (
        'aion.merge(["PART.aion", "PART2.aion", ...], "MAP.aion") scores its days into a map'
    )
    result = run("predict", part.path, "--historical")
    assert result.exit_code == 2
    assert "aion merge PART.aion [PART2.aion ...] -o MAP.aion scores its days" in result.stderr
