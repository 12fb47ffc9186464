"""Entry point of the ``aion`` console script."""

from __future__ import annotations

import click

from aion_cli import __version__


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="aion")
def cli() -> None:
    """aion: 4D scene graphs (scene graphs with temporal flow dynamics) from robot logs."""


def main() -> None:
    cli()
