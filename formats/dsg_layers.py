"""Which layer of a spark_dsg graph is the navigational one (the rule in :mod:`formats.dsg`).

Layer keys and names, ``--nav-layer`` parsing (:func:`parse_nav_layer`), the choice
(:func:`choose_nav_layer`) and the layer listing of messages and ``aion info``
(:func:`graph_layers`, :func:`layers_text`). Only names and keys are looked at here; reading
the chosen layer's nodes into arrays is :mod:`formats.dsg_scan`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from aion_cli.errors import InputError

#: Layer ids of the hierarchy (spark_dsg ``DsgLayers``), used when a graph has no layer names.
PLACES_LAYER = 3
ROOMS_LAYER = 4
BUILDINGS_LAYER = 5
AGENTS_LAYER = 2
MESH_PLACES_PARTITION = 1
#: Where Hydra put its 2D (mesh) places before spark_dsg 1.1 had layer partitions.
LEGACY_MESH_PLACES_LAYER = 20
#: Layer names of keys a graph does not name itself (spark_dsg ``DsgLayers`` defaults).
DEFAULT_LAYER_NAMES: dict[tuple[int, int], str] = {
    (1, 0): "SEGMENTS",
    (2, 0): "OBJECTS",
    (PLACES_LAYER, 0): "PLACES",
    (PLACES_LAYER, MESH_PLACES_PARTITION): "MESH_PLACES",
    (ROOMS_LAYER, 0): "ROOMS",
    (BUILDINGS_LAYER, 0): "BUILDINGS",
    (LEGACY_MESH_PLACES_LAYER, 0): "MESH_PLACES",
}
NAV_LAYER_HINT = (
    "give a layer name (MESH_PLACES, PLACES) or key (3, 3[1], 20) with --nav-layer; "
    "`aion info GRAPH_FILE` lists a graph's layers"
)


class GraphLayerError(InputError):
    """The requested navigational layer is not in the scene graph."""


@dataclass(frozen=True)
class NavLayer:
    """The layer key a navigational graph came from, and its name.

    ``name`` is the upper-case spark_dsg name (the graph's own, else the default of the key;
    ``""`` for a key nobody names); ``legacy`` marks MESH_PLACES found at layer 20.
    """

    layer: int
    partition: int = 0
    name: str = ""
    legacy: bool = False

    @property
    def key(self) -> str:
        """spark_dsg's notation: ``3`` for partition 0, ``3[1]`` otherwise."""
        return str(self.layer) if self.partition == 0 else f"{self.layer}[{self.partition}]"

    @property
    def snapshot_name(self) -> str:
        """The ``GraphSnapshot.layer_name`` (and predict's layer column): ``mesh_places``,
        ``places``, another name in lower case, or ``layer_<key>``."""
        return self.name.lower() if self.name else f"layer_{self.key}"

    def __str__(self) -> str:
        return f"{self.name} ({self.key})" if self.name else self.key


def _named_key(G: Any, name: str, default: tuple[int, int]) -> tuple[int, int]:
    key = G.get_layer_key(name)
    return (int(key.layer), int(key.partition)) if key is not None else default


_KEY_RE = re.compile(r"^(\d+)(?:\[(\d+)\])?$")
_NAME_RE = re.compile(r"^[A-Z][A-Z0-9_]*$")


def parse_nav_layer(layer: str | int | None) -> tuple[int, int] | str | None:
    """The request behind ``--nav-layer``: None (choose by name), a layer key
    ``(layer, partition)`` (``"3[1]"``, ``"20"``, ``3``) or an upper-case layer name
    (``"mesh_places"`` -> ``"MESH_PLACES"``). Bad syntax is a :class:`GraphLayerError`."""
    if layer is None:
        return None
    if isinstance(layer, int) and not isinstance(layer, bool):
        text = str(layer)
    elif isinstance(layer, str):
        text = layer.strip().replace(" ", "")
    else:
        raise GraphLayerError(f"bad navigational layer {layer!r}", hint=NAV_LAYER_HINT)
    m = _KEY_RE.match(text)
    if m:
        key = (int(m.group(1)), int(m.group(2) or 0))
        if max(key) >= 2**32:
            raise GraphLayerError(f"navigational layer key {layer!r} is out of range")
        return key
    name = text.upper().replace("-", "_")
    if _NAME_RE.match(name):
        return name
    raise GraphLayerError(f"bad navigational layer {layer!r}", hint=NAV_LAYER_HINT)


def _graph_names(G: Any) -> dict[str, tuple[int, int]]:
    """The graph's own layer names (spark_dsg >= 1.1 graphs carry them)."""
    names = getattr(G, "layer_names", None) or {}
    return {str(n): (int(k.layer), int(k.partition)) for n, k in dict(names).items()}


def _name_of(G: Any, key: tuple[int, int]) -> tuple[str, bool]:
    """The name of a key (the graph's own first, MESH_PLACES / PLACES preferred) and whether it
    is the legacy MESH_PLACES layer 20."""
    names = _graph_names(G)
    named = [n for n, k in names.items() if k == key]
    for preferred in ("MESH_PLACES", "PLACES", "OBJECTS"):  # OBJECTS and AGENTS share layer 2
        if preferred in named:
            return preferred, False
    if named:
        return sorted(named)[0], False
    name = DEFAULT_LAYER_NAMES.get(key, "")
    if name in names:  # the graph gives this name to another key
        return "", False
    return name, key == (LEGACY_MESH_PLACES_LAYER, 0) and name == "MESH_PLACES"


def _nav(G: Any, key: tuple[int, int]) -> NavLayer:
    name, legacy = _name_of(G, key)
    return NavLayer(key[0], key[1], name, legacy)


def _has(G: Any, key: tuple[int, int]) -> bool:
    return bool(G.has_layer(key[0], key[1]))


def _mesh_place_keys(G: Any) -> list[tuple[int, int]]:
    """Where a graph may keep its 2D places: the key it names MESH_PLACES, ``3[1]`` and the
    legacy layer 20 (the defaults only when the graph does not name them otherwise)."""
    keys = []
    named = _graph_names(G).get("MESH_PLACES")
    if named is not None:
        keys.append(named)
    for key in ((PLACES_LAYER, MESH_PLACES_PARTITION), (LEGACY_MESH_PLACES_LAYER, 0)):
        if key not in keys and _name_of(G, key)[0] == "MESH_PLACES":
            keys.append(key)
    return keys


def graph_layers(G: Any) -> list[tuple[str, str, int]]:
    """Every layer and partition of a graph as ``(key, name, nodes)``, sorted by key."""
    views = list(G.layers) + list(G.layer_partitions)
    rows = {}
    for v in views:
        key = (int(v.id), int(v.partition))
        name = _name_of(G, key)[0]
        if not name and key[1] != 0 and key[0] == _named_key(G, "AGENTS", (AGENTS_LAYER, 0))[0]:
            name = "AGENTS"  # one partition per robot
        rows[key] = (NavLayer(*key).key, name, int(v.num_nodes()))
    return [rows[k] for k in sorted(rows)]


def layers_text(G: Any) -> str:
    """``"3 PLACES (437 nodes), 3[1] MESH_PLACES (96 nodes), ..."`` for messages."""
    return ", ".join(
        f"{key}{' ' + name if name else ''} ({n:,} node{'' if n == 1 else 's'})"
        for key, name, n in graph_layers(G)
    )


def _missing_layer(G: Any, what: str) -> GraphLayerError:
    return GraphLayerError(
        f"scene graph has no layer {what}; its layers: {layers_text(G) or 'none'}",
        hint=NAV_LAYER_HINT,
    )


def choose_nav_layer(G: Any, layer: str | int | None = None) -> NavLayer:
    """The navigational layer of graph ``G`` (see the module docstring for the rule).

    ``layer`` is ``--nav-layer``: None, a name or a key (:func:`parse_nav_layer`). A requested
    layer the graph does not have is a :class:`GraphLayerError` listing the graph's layers.
    """
    request = parse_nav_layer(layer)
    places = _named_key(G, "PLACES", (PLACES_LAYER, 0))
    if request is None:
        for key in _mesh_place_keys(G):
            if _has(G, key) and G.get_layer(*key).num_nodes() > 0:
                return _nav(G, key)
        return _nav(G, places)
    if isinstance(request, tuple):
        if not _has(G, request):
            raise _missing_layer(G, NavLayer(*request).key)
        return _nav(G, request)
    if request == "MESH_PLACES":
        keys = _mesh_place_keys(G)
        found = [k for k in keys if _has(G, k)]
        if not found:
            raise _missing_layer(
                G, "MESH_PLACES (" + " or ".join(NavLayer(*k).key for k in keys) + ")"
            )
        nonempty = [k for k in found if G.get_layer(*k).num_nodes() > 0]
        return _nav(G, (nonempty or found)[0])
    named = _graph_names(G).get(request)
    if named is None and request == "PLACES":
        named = places
    if named is None:
        default = [k for k, n in DEFAULT_LAYER_NAMES.items() if n == request]
        named = default[0] if default else None
    if named is None:
        raise _missing_layer(G, f"named {request}")
    if not _has(G, named):
        raise _missing_layer(G, f"{request} ({NavLayer(*named).key})")
    return NavLayer(named[0], named[1], request)
