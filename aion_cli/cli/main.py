"""Entry point of the ``aion`` console script: the click group and its error handling.

Each subcommand lives in its own module under ``aion_cli.cli`` and is registered below. The
group runs click in non-standalone mode so that :mod:`aion_cli.cli.errors` alone decides what a
failure looks like (one ``error:`` line, a ``hint:`` line, exit code 2 for input errors).
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import MutableMapping, Sequence
from types import FrameType
from typing import Any

import click

from aion_cli import __version__
from aion_cli.cli.errors import EXIT_INTERRUPTED, EXIT_OK, quiet_finalizers, report
from aion_cli.formats.committed import forget_committed

COMMANDS = {
    "info": "aion_cli.cli.info:command",
    "build": "aion_cli.cli.build:command",
    "merge": "aion_cli.cli.merge:command",
    "compact": "aion_cli.cli.compact:command",
    "predict": "aion_cli.cli.predict:command",
    "plan": "aion_cli.cli.plan:command",
    "export": "aion_cli.cli.export:command",
    "report": "aion_cli.cli.report:command",
    "convert": "aion_cli.cli.convert:command",
    "simulate": "aion_cli.cli.simulate:simulate",
    "evaluate": "aion_cli.cli.evaluate:evaluate",
}
"""Each subcommand by name, as ``module:attribute``: imported when it is run (or listed by
``aion --help``), so ``aion predict`` does not load the modules of the build, the
evaluation and the others (about 0.07 s of every query's 1 s, issue 15)."""

EPILOG = """\b
Examples:
  aion info run.mcap                                   what is in a log, what aion will use
  aion build run1.mcap run2.bag -o office.aion         learn a map (incremental with --map)
  aion merge mon.aion tue.aion -o week.aion            one map from maps of disjoint time
  aion compact week.aion -o robot.aion                 a map for queries only (smaller with history)
  aion predict office.aion --time "2026-11-23 08:30"   flows per node at a time
  aion plan office.aion --from p12 --to p87            a path around busy, opposing flows
  aion export office.aion --time "+2h" -o out/         PLY/PCD scenes, CSV/JSON tables
  aion report office.aion -o report/                   an HTML page about a map
  aion simulate -o office.mcap                         a synthetic log to try it all
  aion convert atc.csv --layout atc -o atc.mcap        pedestrian datasets -> logs
  aion evaluate office --scenes 20                     the paper's comparison, predictive metrics

Run 'aion COMMAND --help' for the options and a worked example of each command.
"""


def _debug_requested(args: Sequence[str]) -> bool:
    """``--debug`` anywhere on the command line, or AION_DEBUG=1."""
    return "--debug" in args or os.environ.get("AION_DEBUG", "") not in ("", "0")


def _hoist_debug(args: list[str]) -> list[str]:
    """``aion predict MAP --debug`` works like ``aion --debug predict MAP``: the flag is moved
    in front of the subcommand (only before a ``--`` separator)."""
    end = args.index("--") if "--" in args else len(args)
    if "--debug" not in args[:end]:
        return args
    rest = [a for a in args[:end] if a != "--debug"] + args[end:]
    return ["--debug", *rest]


class AionGroup(click.Group):
    """A click group whose every failure goes through :func:`aion_cli.cli.errors.report`,
    and whose subcommands of :data:`COMMANDS` are imported when first asked for
    (:meth:`get_command`); :attr:`commands` is every one of them, imported."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._lazy: dict[str, str] = {}
        super().__init__(*args, **kwargs)

    @property
    def commands(self) -> MutableMapping[str, click.Command]:
        """Every subcommand (the lazy ones imported now)."""
        for name in list(self._lazy):
            self._load(name)
        return self._commands

    @commands.setter
    def commands(self, value: MutableMapping[str, click.Command]) -> None:
        self._commands = value

    def add_lazy_command(self, name: str, target: str) -> None:
        """Register subcommand ``name`` as ``module:attribute``, imported when first used."""
        self._lazy[name] = target

    def _load(self, name: str) -> None:
        import importlib

        module, attribute = self._lazy.pop(name).split(":")
        command = getattr(importlib.import_module(module), attribute)
        self._commands[name] = command

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name in self._lazy:
            self._load(cmd_name)
        return self._commands.get(cmd_name)

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*self._commands, *self._lazy})

    def main(
        self,
        args: Sequence[str] | None = None,
        prog_name: str | None = None,
        complete_var: str | None = None,
        standalone_mode: bool = True,
        **extra: Any,
    ) -> Any:
        argv = _hoist_debug(list(sys.argv[1:] if args is None else args))
        forget_committed()  # what an interruption reports is this command's
        try:
            rv = super().main(
                argv, prog_name or "aion", complete_var, standalone_mode=False, **extra
            )
            code = rv if isinstance(rv, int) else EXIT_OK
        except click.exceptions.Exit as exc:
            code = exc.exit_code
        except BaseException as exc:  # the single top-level handler
            if isinstance(exc, SystemExit):
                raise
            code = report(exc, _debug_requested(argv))
            if code == EXIT_INTERRUPTED and standalone_mode:
                quiet_finalizers()  # before ``exc`` and the frames it holds are freed
        if not standalone_mode:
            return code
        sys.exit(code)

    def make_context(
        self,
        info_name: str | None,
        args: list[str],
        parent: click.Context | None = None,
        **extra: Any,
    ) -> click.Context:
        """Parse the line (``aion --help`` and ``--version`` print here); stdout closed early
        ends it as in :meth:`invoke`."""
        try:
            return super().make_context(info_name, args, parent, **extra)
        except BrokenPipeError as exc:
            raise click.exceptions.Exit(report(exc, False)) from exc

    def invoke(self, ctx: click.Context) -> Any:
        """Run the subcommand; stdout closed early (``| head``) ends it as
        :func:`aion_cli.cli.errors.report` has it (exit 0, no message), where click's
        ``main`` would make a broken pipe met inside a command exit 1."""
        from aion_cli.cli.console import set_quiet

        set_quiet(False)  # a command's -q lasts for that command only (one process, many runs)
        try:
            return super().invoke(ctx)
        except BrokenPipeError as exc:
            raise click.exceptions.Exit(report(exc, False)) from exc


@click.group(
    "aion",
    cls=AionGroup,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
    epilog=EPILOG,
)
@click.version_option(__version__, "-V", "--version", prog_name="aion")
@click.option(
    "--debug", is_flag=True, help="Show the full traceback when something fails (anywhere)."
)
@click.option(
    "--max-chunk-mb",
    type=float,
    default=None,
    metavar="MIB",
    help="Largest decompressed log chunk to read (default 512, or AION_MAX_CHUNK_MB).",
)
@click.option(
    "--max-message-mb",
    type=float,
    default=None,
    metavar="MIB",
    help="Largest log message to read (default 256, or AION_MAX_MESSAGE_MB).",
)
def cli(debug: bool, max_chunk_mb: float | None, max_message_mb: float | None) -> None:
    """aion: 4D scene graphs (scene graphs with temporal flow dynamics) from robot logs.

    Reads MCAP, ROS 1 bag and rosbag2 logs of Hydra scene graphs and people detections,
    learns where and when people walk in which direction, and predicts, plans and exports from
    the map file it writes.
    """
    _apply_read_limits(max_chunk_mb, max_message_mb)


def _apply_read_limits(max_chunk_mb: float | None, max_message_mb: float | None) -> None:
    """``--max-chunk-mb`` / ``--max-message-mb`` (``aion --max-chunk-mb 2048 build ...``):
    validated here, then handed to every reader of this process through the environment
    variables the readers consult (:meth:`formats.limits.ReadLimits.from_env`)."""
    if max_chunk_mb is None and max_message_mb is None:
        return  # the readers consult the environment themselves, when a log is read
    from aion_cli.formats.limits import CHUNK_ENV, MESSAGE_ENV, ReadLimits

    limits = ReadLimits.of(max_chunk_mb, max_message_mb)  # ConfigError (exit 2) when invalid
    if max_chunk_mb is not None:
        os.environ[CHUNK_ENV] = repr(limits.max_chunk_bytes / 2**20)
    if max_message_mb is not None:
        os.environ[MESSAGE_ENV] = repr(limits.max_message_bytes / 2**20)


for _name, _target in COMMANDS.items():
    cli.add_lazy_command(_name, _target)


def _terminated(signum: int, frame: FrameType | None) -> None:
    """SIGTERM unwinds like Ctrl-C, so a map being written loses only its temporary file and
    its lock (the default action killed the process and left both behind)."""
    raise KeyboardInterrupt


def main() -> None:
    """Console-script entry point."""
    signal.signal(signal.SIGTERM, _terminated)
    cli()
