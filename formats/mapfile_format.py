"""What a ``.aion`` map file is (``formats/MAPFILE.md``): names, version, limits and errors.

The constants, error types and version and member-name rules that writing
(:mod:`formats.mapfile_write`), the output path and its lock (:mod:`formats.mapfile_target`)
and reading (:mod:`formats.mapfile_check`, :mod:`formats.mapfile_read`) share. It imports none
of them, so each can import it; :mod:`formats.mapfile` re-exports everything.
"""

from __future__ import annotations

import re
from typing import Any

import numpy.typing as npt

from aion_cli.errors import AionError, MapFileError, MapVersionError

MAP_FORMAT = "aion-map"
MAP_VERSION = (2, 3)
MANIFEST_NAME = "manifest.json"
MEMBER_SUFFIX = ".npy"

DEFAULT_MAX_MEMBER_BYTES = 4 * 1024**3
"""Largest uncompressed member accepted on read (declared and actual), 4 GiB."""
DEFAULT_MAX_RATIO = 100.0
"""Largest uncompressed/compressed ratio accepted for members above ``RATIO_MIN_BYTES``."""
RATIO_MIN_BYTES = 1024**2
DEFAULT_MAX_MEMBERS = 10_000
"""Most zip entries a map may have (a map written by aion has about 80, a part map 8 more per
day it holds): counted from the zip's end record before its central directory is parsed."""
DEFAULT_MAX_TOTAL_BYTES = 16 * 1024**3
"""Largest sum of the members' uncompressed sizes accepted on read (declared and actual),
16 GiB; also, above ``RATIO_MIN_BYTES``, the sum may not exceed ``max_ratio`` times the file's
size, so many small deflated members (each under the per-member ratio check) cannot expand a
small file into gigabytes."""
MAX_MANIFEST_BYTES = 64 * 1024**2

RESERVED_KEYS = ("format", "version", "creator", "created", "members")
_NAME_RE = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.\-]*(/[A-Za-z0-9_][A-Za-z0-9_.\-]*)*$")
_VERSION_RE = re.compile(r"^(\d+)\.(\d+)$")

ALIGN = 64
"""Members' data start at a multiple of this many bytes in the file (and ``.npy`` headers
are padded to it), so a reader can map an array in place."""
_LOCAL_HEADER_SIZE = 30
"""Fixed part of a zip local file header (signature ... extra field length)."""

Arrays = dict[str, npt.NDArray[Any]]


class MapWriteError(MapFileError):
    """The map file could not be written (disk full, permissions...); any old map is intact."""


class MapContentError(AionError, ValueError):
    """The arrays or manifest handed to :func:`write_map` cannot be stored (a caller bug)."""


# -- names and versions ---------------------------------------------------------------------


def is_valid_member_name(name: str) -> bool:
    """True for array names that are safe as zip member stems.

    Letters, digits, ``_ . -`` and ``/`` as a separator; no empty, ``.`` or ``..`` segments, no
    leading slash, no backslash or drive letters: nothing a careless extractor could turn into a
    path outside its folder.
    """
    if not isinstance(name, str) or not _NAME_RE.match(name) or len(name) > 255:
        return False
    return all(seg not in (".", "..") for seg in name.split("/"))


def format_version(version: tuple[int, int] = MAP_VERSION) -> str:
    """``(1, 0)`` -> ``"1.0"``."""
    return f"{version[0]}.{version[1]}"


def parse_version(text: object) -> tuple[int, int]:
    """``"1.0"`` -> ``(1, 0)``; anything else is a :class:`MapFileError`."""
    match = _VERSION_RE.match(text) if isinstance(text, str) else None
    if match is None:
        raise MapFileError(
            f"map manifest has an invalid version {text!r} (expected 'MAJOR.MINOR')",
            hint="the file is not a valid aion map; rebuild it with `aion build`",
        )
    return int(match.group(1)), int(match.group(2))


def check_version(text: object) -> tuple[int, int]:
    """Accept any minor of our major; a newer (or older) major is a :class:`MapVersionError`."""
    major, minor = parse_version(text)
    ours = MAP_VERSION[0]
    if major > ours:
        raise MapVersionError(
            f"map format {major}.{minor} is newer than this aion supports ({ours}.x); upgrade aion",
            hint="install a newer aion (pip install -U aion) to read this map",
        )
    if major < ours:
        raise MapVersionError(
            f"map format {major}.{minor} is older than this aion supports ({ours}.x)",
            hint="rebuild the map from its logs with `aion build`",
        )
    return major, minor


def check_writable_version(text: object) -> None:
    """Refuse to continue or merge a map of a newer minor of our major.

    Queries read such a map (:func:`check_version`: they ignore what they do not know), but a
    continued or merged map is written in this aion's version, without whatever the newer
    one stored: it would be dropped without a word."""
    major, minor = check_version(text)
    if (major, minor) > MAP_VERSION:
        raise MapVersionError(
            f"map format {major}.{minor} is newer than this aion writes "
            f"({format_version()}): continuing or merging it would drop what the newer "
            "aion stored",
            hint="upgrade aion (pip install -U aion) to continue or merge this map; "
            "predict, plan, export and info read it as it is",
        )
