"""README.md in step with what aion is: every command (``aion evaluate``'s too) has an example
line, every option of ``aion`` itself and every flag's off switch (``--no-...``) is named
(``tests/cli/test_help_consistency.py`` checks the commands' own options), the Python API
section names every name of ``aion_cli.__all__``, the map file section gives the format version
aion writes (formats/MAPFILE.md's), and the supported inputs name every log container
``--log-format`` takes and every detection message type the readers decode.

Found missing when this was written: ``aion --version`` / ``-V``, and ``to_ns``,
``SeriesTable``, ``Manifest``, the reports, ``AionError`` and ``AionWarning`` in the Python API
section."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import click

import aion_cli
from aion_cli.cli.main import cli

REPO = Path(__file__).resolve().parents[2]
README = (REPO / "README.md").read_text()


def _named(word: str, text: str) -> bool:
    """``word`` stands whole in ``text`` (``-o`` is not the start of ``--observed``)."""
    return re.search(rf"(?<![\w-]){re.escape(word)}(?![\w-])", text) is not None


def _section(heading: str) -> str:
    """README's ``## heading`` section, up to the next ``## ``."""
    return README.split(f"\n## {heading}", 1)[1].split("\n## ", 1)[0]


def _commands(command: click.Command, path: tuple[str, ...]) -> Iterator[tuple[str, ...]]:
    if isinstance(command, click.Group):
        for name, sub in command.commands.items():
            yield from _commands(sub, (*path, name))
    else:
        yield path


def _leaf(path: tuple[str, ...]) -> click.Command:
    command: click.Command = cli
    for name in path:
        assert isinstance(command, click.Group)
        command = command.commands[name]
    return command


def test_every_command_has_an_example_line() -> None:
    """An example of each command as a shell line (``aion evaluate door``, not only the
    ``aion evaluate`` group)."""
    commands = list(_commands(cli, ()))
    assert ("evaluate", "holdout") in commands  # the walk reaches a group's commands
    missing = [
        " ".join(path) for path in commands
        if not re.search(rf"^\s*(?:\$ )?aion {re.escape(' '.join(path))}\b", README, re.M)
    ]
    assert not missing, f"README.md has no example line of: {', '.join(missing)}"


def test_every_option_is_named_where_its_command_is_described() -> None:
    """Each command's options in its own ``### `aion X ...``` section (``aion evaluate``'s
    commands share one), or in the options "The commands" describes for all (``-q``):
    ``tests/cli/test_help_consistency.py`` finds an option anywhere in README, so build's
    ``--lineage`` and ``--dsg-version``, info's ``--log-format`` and ``--detections-mapping``,
    merge's ``--nav-layer``, plan's ``--tz``, convert's ``--force`` and evaluate office's
    ``--agents`` passed, though only other commands' text named them."""
    sections = dict(re.findall(r"^### `aion (\w+)[^\n]*\n(.*?)(?=^##)", README, re.M | re.S))
    shared = README.split("\n## The commands", 1)[1].split("\n### ", 1)[0]
    missing = sorted(
        f"{' '.join(path)} {'/'.join(option.opts)}"
        for path in _commands(cli, ()) for option in _leaf(path).params
        if isinstance(option, click.Option) and "--help" not in option.opts
        and not any(_named(opt, sections[path[0]] + shared) for opt in option.opts)
    )
    assert not missing, f"README.md does not name, where it describes the command: {missing}"


def test_aions_own_options_and_every_off_switch_are_named() -> None:
    """``aion --version``, ``--debug``, the read caps (options before the command), and the
    ``--no-...`` half of every ``--x/--no-x`` flag."""
    options = [p for p in cli.params if isinstance(p, click.Option)]
    switches = [
        p for path in _commands(cli, ()) for p in _leaf(path).params
        if isinstance(p, click.Option) and p.secondary_opts
    ]
    assert any(o.opts == ["-V", "--version"] for o in options)
    missing = sorted(
        {"/".join(o.opts) for o in options
         if "--help" not in o.opts and not any(_named(opt, README) for opt in o.opts)}
        | {opt for o in switches for opt in o.secondary_opts if not _named(opt, README)}
    )
    assert not missing, f"README.md does not name: {', '.join(missing)}"


def test_the_python_api_section_names_every_exported_name() -> None:
    section = _section("Python API")
    missing = [name for name in aion_cli.__all__ if f"`{name}`" not in section]
    assert not missing, f"README.md's Python API section does not name: {missing}"


def test_the_map_file_section_gives_the_version_aion_writes() -> None:
    from aion_cli.formats.mapfile_format import MAP_VERSION

    version = ".".join(map(str, MAP_VERSION))
    title = (REPO / "formats" / "MAPFILE.md").read_text().splitlines()[0]
    assert title.endswith(f"format {version}"), title
    stated = re.findall(r"\bFormat (\d+\.\d+)\b", _section("The map file"))
    assert stated == [version], stated


def test_the_supported_inputs_name_every_container_and_detection_type() -> None:
    """Each ``--log-format`` choice and each message type ``aion build`` decodes as people
    detections (``formats.summary.detection_types``), as ``package/Type`` or, in a row of
    its package, its ``Type``."""
    from aion_cli.formats.summary import detection_types

    section = _section("Supported inputs")
    containers = {"mcap": "MCAP", "bag": "ROS 1 `.bag`", "rosbag2": "rosbag2"}
    choices = {
        choice for path in _commands(cli, ())
        for param in _leaf(path).params
        if isinstance(param, click.Option) and "--log-format" in param.opts
        and isinstance(param.type, click.Choice)
        for choice in param.type.choices
    }
    assert choices == set(containers)  # a new container needs its README name here
    assert all(name in section for name in containers.values())
    missing = []
    for msgtype in sorted(detection_types()):
        package, _, name = msgtype.partition("/msg/")
        if f"{package}/{name}" not in section and not _named(name, section):
            missing.append(msgtype)
    assert not missing, f"README.md's Supported inputs do not name: {missing}"

