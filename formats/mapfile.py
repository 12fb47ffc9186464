"""The ``.aion`` map file: a zip of ``manifest.json`` plus one ``.npy`` member per array.

The container is generic over arrays (it knows nothing of the engine's state layout): the caller
hands over ``dict[str, ndarray]`` and a manifest dict of its own fields (config, provenance, time
span, counts...). The format is specified in ``formats/MAPFILE.md``; in short:

- members are stored uncompressed (fast to read, and no decompression bombs in our own files),
  each with its sha256, CRC-32, size, dtype and shape in the manifest's ``members`` table;
- arrays are written with ``allow_pickle=False`` and read with ``allow_pickle=False``: a map file
  never executes code, and object arrays are refused on write;
- writing goes to a temporary file in the same folder, is flushed and fsync'd, then atomically
  renamed over the target, so an interrupted or failed write (full disk, Ctrl-C) leaves any
  previous map intact; a ``<map>.lock`` file stops two writers of the same map;
- reading is defensive: names with path traversal, unexpected or missing members, oversized
  members, suspicious compression ratios, manifests that fail the hand-written schema check,
  checksum mismatches and newer major versions are typed errors, never tracebacks.

This module is the container's public entry point; each name is re-exported from the module
that does the work: :mod:`formats.mapfile_format` (names, version, limits, errors),
:mod:`formats.mapfile_write` (:func:`write_map`), :mod:`formats.mapfile_target` (output-path
checks and :func:`map_lock`), :mod:`formats.mapfile_check` (opening a map: the archive-level
checks, :func:`read_manifest`) and :mod:`formats.mapfile_read` (:func:`open_map`,
:func:`read_map`).
"""

from __future__ import annotations

from aion_cli.formats.mapfile_check import read_manifest, validate_manifest
from aion_cli.formats.mapfile_format import (
    ALIGN,
    DEFAULT_MAX_MEMBER_BYTES,
    DEFAULT_MAX_MEMBERS,
    DEFAULT_MAX_RATIO,
    DEFAULT_MAX_TOTAL_BYTES,
    MANIFEST_NAME,
    MAP_FORMAT,
    MAP_VERSION,
    MAX_MANIFEST_BYTES,
    MEMBER_SUFFIX,
    RATIO_MIN_BYTES,
    RESERVED_KEYS,
    Arrays,
    MapContentError,
    MapWriteError,
    check_version,
    check_writable_version,
    format_version,
    is_valid_member_name,
    parse_version,
)
from aion_cli.formats.mapfile_read import MapMembers, open_map, read_map
from aion_cli.formats.mapfile_target import (
    check_map_folder,
    check_map_output,
    check_map_path,
    check_map_suffix,
    check_map_target,
    is_aion_map,
    map_lock,
)
from aion_cli.formats.mapfile_write import write_map
from aion_cli.formats.output_lock import STALE_UNREADABLE_LOCK_S, lock_path

__all__ = [
    "ALIGN",
    "DEFAULT_MAX_MEMBERS",
    "DEFAULT_MAX_MEMBER_BYTES",
    "DEFAULT_MAX_RATIO",
    "DEFAULT_MAX_TOTAL_BYTES",
    "MANIFEST_NAME",
    "MAP_FORMAT",
    "MAP_VERSION",
    "MAX_MANIFEST_BYTES",
    "MEMBER_SUFFIX",
    "RATIO_MIN_BYTES",
    "RESERVED_KEYS",
    "STALE_UNREADABLE_LOCK_S",
    "Arrays",
    "MapContentError",
    "MapMembers",
    "MapWriteError",
    "check_map_folder",
    "check_map_output",
    "check_map_path",
    "check_map_suffix",
    "check_map_target",
    "check_version",
    "check_writable_version",
    "format_version",
    "is_aion_map",
    "is_valid_member_name",
    "lock_path",
    "map_lock",
    "open_map",
    "parse_version",
    "read_manifest",
    "read_map",
    "validate_manifest",
    "write_map",
]
