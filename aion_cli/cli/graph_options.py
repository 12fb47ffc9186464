"""``--nav-layer``: the one option that picks a scene graph's navigational layer (build,
simulate, info). The rule behind it is :func:`formats.dsg.choose_nav_layer`."""

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
        from formats.dsg import parse_nav_layer

        parse_nav_layer(value)  # GraphLayerError: one `error:` line, exit 2
    return value


def nav_layer_option(func: F) -> F:
    """``--nav-layer NAME|KEY``, passed on as a string (None: chosen by name)."""
    return click.option("--nav-layer", metavar="NAME|KEY", callback=_check, help=NAV_LAYER_HELP)(
        func
    )
