"""Scene-graph options: ``--nav-layer``, the one option that picks a scene graph's
navigational layer (build, simulate, info; the rule behind it is
:func:`formats.dsg.choose_nav_layer`), and build's ``--graph-period`` (how thinly a log's
graph stream is used, :func:`aion_cli.graph_schedule.graph_schedule`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import click

F = TypeVar("F", bound=Callable[..., Any])

NAV_LAYER_HELP = (
    "Scene-graph layer the places are taken from: a name (MESH_PLACES, PLACES) or a layer key "
    "(3, 3[1], 20) [default: MESH_PLACES (3[1], or layer 20 in older graphs) when the graph "
    "has 2D places, else PLACES]."
)


def _check(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """Fail on bad syntax before any file is read (the layer itself is checked per graph)."""
    if value is not None:
        from aion_cli.formats.dsg import parse_nav_layer

        parse_nav_layer(value)  # GraphLayerError: one `error:` line, exit 2
    return value


def nav_layer_option(func: F) -> F:
    """``--nav-layer NAME|KEY``, passed on as a string (None: chosen by name)."""
    return click.option("--nav-layer", metavar="NAME|KEY", callback=_check, help=NAV_LAYER_HELP)(
        func
    )


def _period(ctx: click.Context, param: click.Parameter, value: str | None) -> int | None:
    from aion_cli.graph_schedule import parse_period_ns

    return None if value is None else parse_period_ns(value)


#: ``--graph-period``'s default as the help shows it: ``aion_cli.graph_feed``'s
#: ``DEFAULT_GRAPH_PERIOD_NS`` (not imported here: ``aion --help`` must stay light; a test
#: checks that the two agree).
GRAPH_PERIOD_DEFAULT_TEXT = "5s"


def graph_period_option(func: F) -> F:
    """``--graph-period DURATION`` (log time), passed on as integer ns (None: the build's
    default, :data:`aion_cli.graph_schedule.DEFAULT_GRAPH_PERIOD_NS`)."""
    return click.option(
        "--graph-period",
        "graph_period_ns",
        metavar="DURATION",
        callback=_period,
        help="Use about one scene graph per DURATION of log time (5s, 1m, 500ms; 0: every "
        "graph): the newest graph of each period, the last of each window and of the log "
        "(one that is a partial update gives way to the next whole graph of its window); "
        "a payload identical to the last one is never decoded again "
        f"[default: {GRAPH_PERIOD_DEFAULT_TEXT}].",
    )(func)
