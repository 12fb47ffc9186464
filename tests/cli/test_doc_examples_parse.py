"""Every example command line the documents and the ``--help`` texts give parses as the
command it names: its options exist there (not renamed, not another command's), a choice
is one of the option's choices, and its file arguments are files, not a description that
lost the spaces setting it apart (``aion build run1.mcap run2.bag -o office.aion several logs,
...`` in ``aion build --help`` gave aion the logs "several" and "logs,")."""

from __future__ import annotations

import re
import shlex
from collections.abc import Iterator
from pathlib import Path

import click
import pytest

from aion_cli.cli.main import cli

REPO = Path(__file__).resolve().parents[2]
DOCUMENTS = ["README.md", "formats/MAPFILE.md", *sorted(
    str(p.relative_to(REPO)) for p in (REPO / "docs").glob("*.md")
)]


def _joined(lines: list[str]) -> Iterator[str]:
    """The lines, each ``\\``-continued one joined with the next."""
    pending = ""
    for line in lines:
        if line.rstrip().endswith("\\"):
            pending += line.rstrip()[:-1].strip() + " "
            continue
        yield pending + line.strip()
        pending = ""


def _from_documents() -> Iterator[tuple[str, str]]:
    """(where, command) of each ``aion ...`` line in the documents' plain code blocks."""
    for name in DOCUMENTS:
        block: str | None = None
        lines: list[str] = []
        for line in (REPO / name).read_text().splitlines():
            if line.startswith("```"):
                if block is not None and block in ("", "sh", "bash", "console"):
                    yield from ((name, c) for c in _joined(lines) if c.startswith("aion "))
                block, lines = (line[3:].strip() if block is None else None), []
                continue
            if block is not None:
                lines.append(line.split("  #", 1)[0].split(" # ", 1)[0])


def _commands(
    group: click.Group, path: str = "aion"
) -> Iterator[tuple[str, click.Command]]:
    """(``aion evaluate holdout``, its command) of the group and every command under it."""
    yield path, group
    for name, command in group.commands.items():
        if isinstance(command, click.Group):
            yield from _commands(command, f"{path} {name}")
        else:
            yield f"{path} {name}", command


def _from_help() -> Iterator[tuple[str, str]]:
    """(where, command) of each example of every ``--help``: its text up to the run of
    spaces before the description."""
    for path, command in _commands(cli):
        text = f"{command.help or ''}\n{command.epilog or ''}"
        examples, lines = False, []
        for line in text.splitlines():
            heading = line.strip() in ("Example:", "Examples:")
            examples = heading or (examples and bool(line.strip()))
            lines += [line] if examples else []
        for line in _joined(lines):
            if line.startswith("aion "):
                yield f"{path} --help", re.split(r" {2,}", line, maxsplit=1)[0]


EXAMPLES = sorted(set(_from_documents()) | set(_from_help()))


def _words(command: str) -> list[str]:
    """The shell words of the ``aion`` command, up to a pipe or a redirection."""
    lexer = shlex.shlex(command, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    words = []
    for word in lexer:
        if word and set(word) <= set("|&;<>()"):
            break
        words.append(word)
    return words


def _given(value: object) -> list[str]:
    """The strings the parser took for a parameter (none when it was not given)."""
    items = value if isinstance(value, (list, tuple)) else [value]
    return [item for item in items if isinstance(item, str)]


def _parse(words: list[str]) -> None:
    """Parse ``words`` (after ``aion``) as click would, without running anything: unknown
    options, missing values, choices and extra arguments raise click's own errors."""
    command: click.Command = cli
    args = words
    while True:
        ctx = click.Context(command, info_name=command.name, resilient_parsing=False)
        values, rest, order = command.make_parser(ctx).parse_args(args=list(args))
        for param in order:
            given = _given(values.get(param.name))
            if isinstance(param.type, click.Choice):
                for item in given:
                    param.type.convert(item, param, ctx)
            if isinstance(param, click.Argument) and isinstance(param.type, click.Path):
                for item in given:
                    # a file or folder (run.mcap, rosbag2_folder/, day*.mcap) or a
                    # placeholder (LOG, MAP), not a word of a description
                    assert re.search(r"[./*]", item) or item.isupper(), (
                        f"argument {item!r} of aion {command.name} is no file: a description "
                        "without the spaces before it?"
                    )
        if not isinstance(command, click.Group):
            if rest:
                raise click.UsageError(f"unexpected extra arguments {rest}")
            if words and "--print-config" not in words and "--help" not in words:
                for param in command.params:
                    if param.required and not _given(values.get(param.name)):
                        raise click.MissingParameter(ctx=ctx, param=param)
            return
        if not rest:
            raise click.UsageError("no command after the options")
        name, args = rest[0], rest[1:]
        sub = command.get_command(ctx, name)
        if sub is None:
            raise click.UsageError(f"no such command {name!r}")
        command = sub


def test_the_examples_are_found() -> None:
    """The collection itself: the README's examples, DESIGN's outline, every help's."""
    where = {w for w, _ in EXAMPLES}
    helps = {"aion --help", "aion build --help", "aion evaluate holdout --help"}
    assert {"README.md", "docs/DESIGN.md", *helps} <= where
    assert ("README.md", 'aion predict office.aion --time "monday 08:30" --layer rooms') in (
        EXAMPLES
    )
    assert len(EXAMPLES) > 120


@pytest.mark.parametrize(("where", "command"), EXAMPLES)
def test_an_example_parses_as_its_command(where: str, command: str) -> None:
    if "..." in _words(command):  # an outline (docs/DESIGN.md: aion evaluate ...)
        return
    try:
        _parse(_words(command)[1:])
    except click.ClickException as exc:
        pytest.fail(f"{where}: {command}\n  {exc.format_message()}")


@pytest.mark.parametrize(
    "command",
    [
        "aion merge old.aion new.aion -o both.aion --lineages different",  # renamed option
        "aion merge old.aion new.aion -o both.aion --lineage differing",  # not a choice
        "aion predict office.aion --time now --path-from p1",  # another command's option
        "aion build run1.mcap -o office.aion several logs",  # a description, no spaces
        "aion export office.aion --time",  # a value missing
        "aion simulate --days 2",  # -o required
        "aion evaluate officer",  # no such command
    ],
)
def test_a_broken_example_is_refused(command: str) -> None:
    """The checks above can fail: each mistake they look for, made once."""
    with pytest.raises((click.ClickException, AssertionError)):
        _parse(_words(command)[1:])
