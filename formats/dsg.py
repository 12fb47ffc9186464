"""Hydra / spark_dsg scene graphs -> :class:`GraphSnapshot`.

Three entry points:

- :func:`decode_dsg_update` decodes the ``layer_contents`` payload of a ``hydra_msgs/DsgUpdate``
  message. ROS payloads carry no version header and spark_dsg's binary format is positional, so a
  payload written by an older spark_dsg makes ``from_binary`` throw. We then retry through the
  versioned-header fallback (``../shared/reference/notes-formats.md`` §1.4): put a 29-byte
  ``SPARK_DSG`` file header naming an older version in front of the payload, write it to a
  temporary ``.sparkdsg`` and ``DynamicSceneGraph.load`` it. A wrong version fails loudly, so
  trying versions newest first is safe. :func:`decode_dsg` also reports which version worked so a
  caller can pin it for the rest of a log (each failed try costs a parse and a warning line that
  spark_dsg prints itself).
- :func:`load_graph` reads Hydra's saved files (``dsg.json``, ``dsg_with_mesh.json``,
  ``.sparkdsg``, legacy header-less JSON); a JSON file spark_dsg refuses is read leniently
  (:mod:`formats.dsg_json`) and the result says what was skipped.
- :func:`navigation` (behind all of them, and :func:`snapshot_from_dsg`) turns any spark_dsg graph
  into the navigational :class:`GraphSnapshot`.

**Payloads without spark_dsg.** A live Hydra sends a DsgUpdate every second; building it as
spark_dsg objects and reading them back node by node cost ~50 ms for 5,000 places.
:func:`decode_dsg` therefore first reads a payload in the installed spark_dsg's own layout with
numpy (:mod:`formats.dsg_binary`, :mod:`formats.dsg_fast`: ~8 ms) and gives spark_dsg every
payload that reader does not vouch for, so results and errors are the same either way
(``tests/formats/test_dsg_fast.py``).

**One navigational layer rule for every command that reads a scene graph** (build, simulate and
the evaluation through it, info; predict / plan / export read the graph stored in the map):
layers are spark_dsg *keys*, a layer id and a partition (``3[1]``). Without a choice, the 2D
places are taken when the graph has any — the layer the graph names ``MESH_PLACES`` (spark_dsg
1.1.x: partition 1 of layer 3, ``3[1]``; older Hydra graphs: layer 20) — else ``PLACES``
(layer 3). ``--nav-layer NAME|KEY`` (``MESH_PLACES``, ``PLACES``, any name the graph gives a
layer, ``3[1]``, ``20``) overrides it; :func:`parse_nav_layer` checks its syntax.

spark_dsg is imported inside the functions (heavy import, see docs/CONTRACTS.md).

**Damaged input.** spark_dsg trusts the length fields of its binary format: a vector is
resized to the length it reads before its elements are, so one flipped length byte asks for
gigabytes (``std::bad_alloc``, or gigabytes really touched). Two defences:

- :func:`binary_problem` walks a ``.sparkdsg`` file's token stream (spark_dsg's msgpack subset,
  see the function) before spark_dsg sees it: an array that claims more elements than bytes
  follow, a cut-short value or a byte that is no value is a :class:`GraphFileError` naming
  the byte, exit 2. A valid file always passes (the walk accepts when *any* reading of the
  bytes is valid); a 110 MB graph with a 10^6-vertex mesh takes ~0.5 s.
- every spark_dsg parse (files and DsgUpdate payloads, which are too many to walk) runs under
  :func:`_memory_budget`: the process's address space may grow by at most
  :data:`GRAPH_MEMORY_BASE` + :data:`GRAPH_MEMORY_FACTOR` x the input's size, so a damaged
  length becomes a MemoryError (a decode error) instead of a machine out of memory.

**Where the code is.** This module is the public entry point: every name below is
re-exported from the module that does the work — :mod:`formats.dsg_payload` (payload
versions, the versioned-header fallback, :func:`decode_dsg`), :mod:`formats.dsg_guard` (the
damaged-input defences), :mod:`formats.dsg_files` (graph files, :func:`load_graph`),
:mod:`formats.dsg_layers` (the navigational-layer rule) and :mod:`formats.dsg_scan`
(:func:`navigation`: nodes, edges, mesh and agents as arrays), with the numpy payload reader in
:mod:`formats.dsg_binary` / :mod:`formats.dsg_binary_fields` and :mod:`formats.dsg_fast`. The
underscore names are re-exported for :mod:`formats.dsg_json` and the tests, which reach into
the parts.
"""

from __future__ import annotations

from aion_cli.formats.dsg_files import (
    GraphFile,
    GraphFileError,
    LoadedGraph,
    load_dsg_file,
    load_graph,
    load_graph_file,
    read_dsg_file,
)
from aion_cli.formats.dsg_guard import (
    GRAPH_MEMORY_BASE,
    GRAPH_MEMORY_FACTOR,
    _memory_budget,
    binary_problem,
)
from aion_cli.formats.dsg_layers import (
    AGENTS_LAYER,
    BUILDINGS_LAYER,
    DEFAULT_LAYER_NAMES,
    LEGACY_MESH_PLACES_LAYER,
    MESH_PLACES_PARTITION,
    NAV_LAYER_HINT,
    PLACES_LAYER,
    ROOMS_LAYER,
    GraphLayerError,
    NavLayer,
    choose_nav_layer,
    graph_layers,
    layers_text,
    parse_nav_layer,
)
from aion_cli.formats.dsg_payload import (
    FALLBACK_VERSIONS,
    DecodedGraph,
    PayloadLike,
    _candidate_versions,
    _native_output_silenced,
    _short,
    decode_dsg,
    decode_dsg_update,
    installed_version,
    read_dsg_payload,
    spark_header,
)
from aion_cli.formats.dsg_scan import (
    NavGraph,
    _labels,
    _LayerScan,
    _scan,
    _symbol_strings,
    navigation,
    snapshot_from_dsg,
)

__all__ = [
    "AGENTS_LAYER",
    "BUILDINGS_LAYER",
    "DEFAULT_LAYER_NAMES",
    "FALLBACK_VERSIONS",
    "GRAPH_MEMORY_BASE",
    "GRAPH_MEMORY_FACTOR",
    "LEGACY_MESH_PLACES_LAYER",
    "MESH_PLACES_PARTITION",
    "NAV_LAYER_HINT",
    "PLACES_LAYER",
    "ROOMS_LAYER",
    "DecodedGraph",
    "GraphFile",
    "GraphFileError",
    "GraphLayerError",
    "LoadedGraph",
    "NavGraph",
    "NavLayer",
    "PayloadLike",
    "_LayerScan",
    "_candidate_versions",
    "_labels",
    "_memory_budget",
    "_native_output_silenced",
    "_scan",
    "_short",
    "_symbol_strings",
    "binary_problem",
    "choose_nav_layer",
    "decode_dsg",
    "decode_dsg_update",
    "graph_layers",
    "installed_version",
    "layers_text",
    "load_dsg_file",
    "load_graph",
    "load_graph_file",
    "navigation",
    "parse_nav_layer",
    "read_dsg_file",
    "read_dsg_payload",
    "snapshot_from_dsg",
    "spark_header",
]
