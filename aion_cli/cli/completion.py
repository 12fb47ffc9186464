"""Shell completion of node ids from the map on the command line.

Click completes commands, options, choices and paths by itself (``eval "$(_AION_COMPLETE=
bash_source aion)"``, README); this module adds the ids a map holds, so that ``aion plan
office.aion --from p<TAB>`` lists the map's places, ``--from R<TAB>`` its rooms, and
``--from k<TAB>`` the rooms and buildings named so in the scene graph ("kitchen"; a name with
spaces as one word, ``office_1``, which every command reads back). The map is
read as queries read it (its graph and its entries' node ids; about 0.15 s for the sample
office), and a completion never fails: whatever goes wrong (no map yet on the line, a damaged
file) completes nothing rather than printing a traceback into the shell.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click
from click.shell_completion import CompletionItem

#: at most this many ids are offered (a shell lists them all)
MOST = 500


def node_ids_of(map_path: Path) -> tuple[list[str], list[str]]:
    """The place, room and building ids of the map's scene graph and the node ids of its
    entries, in natural order (p2 before p10); and the graph's room and building names as
    shell words (:func:`aion_cli.room_names.shell_word`)."""
    import numpy as np

    from aion_cli.engine.node_ids import node_labels
    from aion_cli.mapquery import load_map
    from aion_cli.room_names import room_names, shell_word

    loaded = load_map(map_path, forecast_only=True)  # as queries read it
    parts = [np.asarray(loaded.state.entries.node_id, dtype=np.uint64)]
    graph = loaded.graph
    names: list[str] = []
    if graph is not None:
        parts += [graph.places.ids, graph.rooms.ids, graph.buildings.ids]
        words = (shell_word(name) for name in room_names(graph))
        names = sorted({w for w in words if w is not None}, key=str.casefold)
    ids = np.unique(np.concatenate([p.astype(np.uint64) for p in parts]))
    ids = ids[ids != 0]  # hash cells have no node id
    labels = sorted(node_labels(ids).tolist(), key=_natural)
    return labels, names


def _natural(label: str) -> tuple[str, int, str]:
    head = label.rstrip("0123456789")
    digits = label[len(head) :]
    return (head, int(digits) if digits else -1, label)


def _typed_map_path(ctx: click.Context, incomplete: str) -> str | None:
    """The MAP already typed on the line. Click leaves ``ctx.params`` unset while an option
    waits for its value (pallets/click#2184), so the words the shell passed (``COMP_WORDS``,
    the same variable in every shell click supports) are parsed again without that option."""
    import os

    from click.shell_completion import split_arg_string

    typed = ctx.params.get("map_path")
    if typed is not None:
        return str(typed)
    words = split_arg_string(os.environ.get("COMP_WORDS", ""))
    cword = os.environ.get("COMP_CWORD", "")
    if cword.isdigit():
        words = words[: int(cword)]
    elif words and incomplete and words[-1] == incomplete:
        words = words[:-1]  # fish passes the line up to the cursor, the current word last
    if ctx.info_name not in words[1:]:
        return None
    args = words[words.index(ctx.info_name, 1) + 1 :]
    if args and args[-1].startswith("-"):
        args = args[:-1]  # the option whose value is being completed
    parsed = ctx.command.make_context(
        ctx.info_name, args, parent=ctx.parent, resilient_parsing=True
    )
    value = parsed.params.get("map_path")
    return None if value is None else str(value)


def _complete(ctx: click.Context, incomplete: str) -> list[CompletionItem]:
    try:
        map_path = _typed_map_path(ctx, incomplete)
        if map_path is None:
            return []
        labels, names = node_ids_of(Path(map_path))
    except Exception:  # a completion must never break the shell line
        return []
    typed = incomplete.casefold()  # names match in any case, ids as typed (p and P differ)
    matching = [label for label in labels if label.startswith(incomplete)]
    matching += [n for n in names if n.casefold().startswith(typed) and n not in labels]
    return [CompletionItem(label) for label in matching[:MOST]]


def complete_nodes(ctx: click.Context, param: Any, incomplete: str) -> list[CompletionItem]:
    """``predict --node``, ``plan --from/--to``, ``export --path-from/--path-to``: the map's
    places, rooms and buildings."""
    return _complete(ctx, incomplete)
