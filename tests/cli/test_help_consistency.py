"""One concept, one spelling: options that several commands share read the same in every
``--help`` (metavar), and the help says what an option left out means."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import click
import pytest

from aion_cli.cli.main import cli

SHARED = (
    "--base-frame",
    "--config",
    "--data",
    "--detections-mapping",
    "--detections-topic",
    "--graph",
    "--graph-topic",
    "--log-format",
    "--map-frame",
    "--nav-layer",
    "--observed",
    "--png",
    "--radius",
    "--step",
    "--time",
    "--tz",
)
"""Options that mean the same wherever they appear (``--from`` is a time in predict and
export but a place in plan; ``-o`` a file or a folder; ``--format`` each command's own)."""


def _options() -> Iterator[tuple[str, click.Option, click.Context]]:
    def walk(command: click.Command, path: list[str]) -> Iterator[tuple[str, click.Option,
                                                                        click.Context]]:
        if isinstance(command, click.Group):
            for name, sub in command.commands.items():
                yield from walk(sub, [*path, name])
            return
        ctx = click.Context(command, info_name=path[-1])
        for param in command.params:
            if isinstance(param, click.Option):
                yield " ".join(path), param, ctx

    yield from walk(cli, [])


def _metavar(option: click.Option, ctx: click.Context) -> str:
    record = option.get_help_record(ctx)
    assert record is not None
    return record[0].split(" ", 1)[1] if " " in record[0] else ""


@pytest.mark.parametrize("name", SHARED)
def test_a_shared_option_has_one_metavar(name: str) -> None:
    """``--map-frame TEXT`` beside ``FRAME`` elsewhere, ``--config PATH`` in evaluate but
    ``FILE`` in build, ``--data PATH`` for a folder: the same value reads the same."""
    seen = {
        command: _metavar(option, ctx).split(", ")[-1]
        for command, option, ctx in _options()
        if name in option.opts
    }
    assert len(seen) >= 2, seen
    assert len(set(seen.values())) == 1, seen
    assert "TEXT" not in seen.values(), seen
    assert "PATH" not in seen.values(), seen


def test_every_time_option_says_what_leaving_it_out_means() -> None:
    """predict and plan say ``[default: now]``; export, which also predicts at now without
    --time, said nothing; every --tz names its default but simulate's did not."""
    for command, option, ctx in _options():
        if "--time" in option.opts or "--tz" in option.opts:
            record = option.get_help_record(ctx)
            assert record is not None
            assert "default: " in record[1], (command, record)


def test_every_tz_option_offers_the_machines_zone() -> None:
    """README: ``--tz local`` is the machine's zone "in every command that takes --tz", and
    every such command takes it; only info's help said so."""
    helps = {
        command: record[1] for command, option, ctx in _options() if "--tz" in option.opts
        for record in [option.get_help_record(ctx)] if record is not None
    }
    assert {"build", "predict", "plan", "export", "report", "convert", "simulate", "info"} <= set(
        helps
    )
    assert {command for command, text in helps.items() if "local" not in text} == set()


def test_frames_and_files_are_named_as_such() -> None:
    """The frame options read FRAME, model parameters FILE, data folders DIR, a count N."""
    expected = {"--map-frame": "FRAME", "--base-frame": "FRAME", "--config": "FILE",
                "--data": "DIR", "--top": "N"}
    for command, option, ctx in _options():
        for name, metavar in expected.items():
            if name in option.opts:
                assert _metavar(option, ctx) == metavar, (command, name)


def test_every_choice_takes_any_case() -> None:
    """``--format JSON`` and ``--container MCAP`` were accepted but ``predict --layer Rooms``,
    ``simulate --robot Fixed`` or ``evaluate --protocol Chronological`` refused: every option
    of fixed words now takes them in any case (and passes on the word as listed)."""
    choices = [
        (command, option) for command, option, _ in _options()
        if isinstance(option.type, click.Choice)
    ]
    assert any(command == "predict" and "--layer" in option.opts for command, option in choices)
    refused = [
        (command, option.opts[0]) for command, option in choices
        if option.type.case_sensitive  # type: ignore[attr-defined]
    ]
    assert refused == []


def test_every_choice_is_named_as_listed(tmp_path: Path) -> None:
    """A choice taken in any case is still shown and named in its own case: click 8.2 on
    printed ``--message-type [spencer_tracking_msgs/msg/trackedpersons|geometry_msgs/msg/
    posearray]``, types no log holds, in the help and in the error for a word not listed."""
    from tests.cli.conftest import run

    shown = {
        (command, option.opts[0]): (_metavar(option, ctx).rsplit(" ", 1)[-1], option.type.choices)
        for command, option, ctx in _options()
        if isinstance(option.type, click.Choice) and option.metavar is None
    }
    assert ("convert", "--message-type") in shown
    wrong = {
        where: metavar for where, (metavar, choices) in shown.items()
        if metavar != "[" + "|".join(map(str, choices)) + "]"
    }
    assert wrong == {}
    tracks = tmp_path / "t.csv"
    tracks.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n")
    result = run("convert", tracks, "-o", tmp_path / "t.mcap", "--message-type", "posearray")
    assert result.exit_code == 2
    assert ("'posearray' is not one of 'spencer_tracking_msgs/msg/TrackedPersons', "
            "'geometry_msgs/msg/PoseArray'.") in result.stderr
    assert not (tmp_path / "t.mcap").exists()


def test_readme_commands_can_be_pasted_into_a_shell() -> None:
    """A README example is a shell line: its comment starts with ``#`` (``aion plan ...
    --to "office 1"   room to room`` passed 'room to room, ...' to aion, which refused the
    extra arguments)."""
    import re
    import shlex
    from pathlib import Path

    readme = Path(__file__).resolve().parents[2] / "README.md"
    block: str | None = None  # the language of the fenced block the line is in
    for number, line in enumerate(readme.read_text().splitlines(), 1):
        if line.startswith("```"):
            block = line[3:] if block is None else None
            continue
        if block != "" or not line.startswith("aion "):
            continue
        command = line.split("#", 1)[0].rstrip().rstrip("\\")
        words = shlex.split(command)
        # a description left without '#' follows the command after a run of spaces
        assert not re.search(r"\S {3,}[a-z(]", command), (number, line)
        assert words[0] == "aion", (number, line)


@pytest.mark.parametrize("args", [(), ("evaluate",)])
def test_a_group_alone_prints_its_help_whole(args: tuple[str, ...]) -> None:
    """``aion`` (or ``aion evaluate``) alone: click 8.2 on reports the help as a usage error,
    which the one-line form flattened into 'error: Usage: aion [OPTIONS] ...; aion: 4D scene
    graphs ...; Options:; -V, --version ...'. The help is printed as --help prints it, on
    stderr, exit 2 (no command given)."""
    from tests.cli.conftest import run

    if not hasattr(click.exceptions, "NoArgsIsHelpError"):
        pytest.skip("click 8.1 prints the help itself (stdout, exit 0)")
    result = run(*args)
    assert result.exit_code == 2
    assert result.stdout == ""
    assert result.stderr.startswith("Usage: aion")
    assert "error:" not in result.stderr
    assert "\nCommands:\n" in result.stderr
    assert result.stderr.rstrip("\n") == run(*args, "--help").stdout.rstrip("\n")


@pytest.mark.parametrize("command", ["build", "merge"])
def test_quiet_says_it_silences_the_notes(command: str) -> None:
    """``build -q`` and ``merge -q`` leave out the notes too ('x.aion existed and is
    replaced', the lineage and merge approximations), which their help did not say."""
    from tests.cli.conftest import run

    help_text = " ".join(run(command, "--help").stdout.split())
    assert "-q, --quiet No progress" in help_text
    assert "notes" in help_text.split("-q, --quiet", 1)[1].split("--", 1)[0]


def test_a_log_container_has_one_name_in_simulate_and_convert(tmp_path: Path) -> None:
    """simulate chose the container with ``--format rosbag2``, convert with ``--container
    rosbag2-mcap``: each refused the other's spelling. Both take both."""
    from tests.cli.conftest import run

    simulated = tmp_path / "sim"
    result = run("simulate", "-o", simulated, "--container", "rosbag2-mcap", "--days", "0.02",
                 "-q")
    assert result.exit_code == 0, result.stderr
    assert sorted(p.suffix for p in simulated.iterdir()) == [".mcap", ".yaml"]

    tracks = tmp_path / "tracks.csv"
    start = 1767600000 * 10**9
    rows = (f"{start + k * 500_000_000},1,{0.6 * k:.1f},0,0,0,1.2\n" for k in range(10))
    tracks.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n" + "".join(rows))
    converted = tmp_path / "conv"
    result = run("convert", tracks, "-o", converted, "--container", "rosbag2")
    assert result.exit_code == 0, result.stderr
    assert sorted(p.suffix for p in converted.iterdir()) == [".mcap", ".yaml"]


def test_convert_and_build_read_one_observed_span_alike(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a machine in Berlin, ``convert --observed "2026-01-05 08:00..10:00"`` read the span
    in the machine's zone (07:00..09:00 UTC) where ``build --observed`` reads the same text
    in UTC: one span, two meanings. Both read a time without a zone in --tz, else UTC."""
    import json

    from tests.cli.conftest import run

    monkeypatch.setenv("TZ", "Europe/Berlin")
    tracks = tmp_path / "tracks.csv"
    start = 1767603600 * 10**9  # 2026-01-05 09:00 UTC
    rows = (f"{start + k * 500_000_000},1,{0.6 * k:.1f},0,0,0,1.2\n" for k in range(10))
    tracks.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n" + "".join(rows))
    log = tmp_path / "tracks.mcap"
    result = run("convert", tracks, "-o", log, "--observed", "2026-01-05 08:00..2026-01-05 10:00")
    assert result.exit_code == 0, result.stderr
    info = json.loads(run("info", log, "--format", "json").stdout)
    assert info["start"] == "2026-01-05T08:00:00.000000Z"
    # the span's last marker is 1 ns before its end: 09:59:59.999999999, cut to the microsecond
    # (it read 10:00:00.000000 through float seconds, rounded up)
    assert info["end_ns"] == start + 3600 * 10**9 - 1
    assert info["end"] == "2026-01-05T09:59:59.999999Z"


def test_every_format_option_takes_any_case() -> None:
    """``--format JSON`` worked in predict, build, info, evaluate ..., ``export --format PNG``
    and ``simulate --format BAG`` were refused: every --format (and --log-format, --container)
    reads its choices in any case."""
    for command, option, _ctx in _options():
        if {"--format", "--log-format", "--container"} & set(option.opts):
            assert isinstance(option.type, click.Choice), command
            assert not option.type.case_sensitive, command


@pytest.mark.parametrize("group", [(), ("evaluate",)])
def test_a_command_list_cuts_no_summary(group: tuple[str, ...]) -> None:
    """``aion --help`` listed 'evaluate  Evaluate aion: against a grid Map of Dynamics, on
    real...' and 'simulate  Simulate people in an office (or any scene graph) seen by a...'
    (click cuts a docstring's first sentence to fit 80 columns); every command has a short
    help that fits."""
    from tests.cli.conftest import run

    listing = run(*group, "--help").stdout.split("Commands:", 1)[1]
    assert "..." not in listing


def test_every_option_is_named_in_the_readme() -> None:
    """Every option of every command appears in README.md (a new user reading it meets each,
    --help gives the detail): simulate's --seed, --rate, --noise, --frame, its patrol and
    period options, evaluate's --radius, --per-hour, --keep and --skip, build's --batch-size
    and convert's --message-type were in --help only."""
    import re

    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()

    def named(opt: str) -> bool:  # a whole option: -o is not the start of --observed
        return re.search(rf"(?<![\w-]){re.escape(opt)}(?![\w-])", readme) is not None

    missing = sorted(
        f"{command} {'/'.join(option.opts)}"
        for command, option, _ in _options()
        if "--help" not in option.opts and not any(named(opt) for opt in option.opts)
    )
    assert not missing, f"README.md does not name: {', '.join(missing)}"


def test_workers_help_and_docs_say_how_close_the_parallel_map_is() -> None:
    """``build --help`` said the shards are joined "into exactly the map a sequential build
    makes", but a join adds a shard's float sums at once where one process adds them term by
    term: maps of ``--workers 1`` and ``--workers 2`` differ in the last bits of speed and
    heading sums (6e-16 relative on three simulated days). The help, README and SCALING.md
    say floats to rounding, within the tolerance the parallel-build tests hold them to
    (``engine.compare.differences``' rtol)."""
    import inspect

    from aion_cli.engine.compare import differences
    from tests.cli.conftest import run

    rtol = inspect.signature(differences).parameters["rtol"].default
    help_text = " ".join(run("build", "--help").stdout.split())
    assert "exactly the map" not in help_text
    assert f"float sums to rounding (a join adds a part's sums at once, one process term by " \
        f"term: the last bits can differ, within {rtol:g} relative)" in help_text
    workers = help_text.split("--workers N", 1)[1].split("--", 1)[0]
    assert "float sums to rounding" in workers
    root = Path(__file__).resolve().parents[2]
    readme = " ".join((root / "README.md").read_text().split())
    assert "the result is exact either way" not in readme
    assert "float sums to rounding" in readme.split("*Parallel builds.*", 1)[1][:600]
    scaling = " ".join((root / "docs" / "SCALING.md").read_text().split())
    assert "Exact either way" not in scaling
    assert "Not bit for bit" in scaling
