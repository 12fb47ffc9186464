"""spark_dsg payloads -> graphs: the versioned-header fallback and DsgUpdate decoding.

A ``hydra_msgs/DsgUpdate`` payload carries no version header, so one written by an older
spark_dsg is read by putting a ``SPARK_DSG`` file header naming that version in front of it
(:func:`read_dsg_payload`, see :mod:`formats.dsg`). This module knows the spark_dsg versions
and how to call spark_dsg quietly; which layer becomes the navigational graph is
:mod:`formats.dsg_layers` and :mod:`formats.dsg_scan`, reading files is
:mod:`formats.dsg_files`.
"""

from __future__ import annotations

import contextlib
import functools
import os
import tempfile
from dataclasses import dataclass
from importlib import metadata
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import GraphSnapshot
from aion_cli.errors import MessageDecodeError
from aion_cli.formats.dsg_guard import _memory_budget
from aion_cli.formats.dsg_layers import PLACES_LAYER, NavLayer
from aion_cli.formats.dsg_scan import navigation

if TYPE_CHECKING:
    from aion_cli.formats.dsg_delta import GraphReader

#: Older payload versions tried, newest first, when the installed spark_dsg cannot read a payload.
#: Before 1.0.2 (kimera_dsg era) spark_dsg itself refuses to read.
FALLBACK_VERSIONS: tuple[str, ...] = (
    "1.1.2",
    "1.1.1",
    "1.1.0",
    "1.0.6",
    "1.0.5",
    "1.0.4",
    "1.0.3",
    "1.0.2",
)


PayloadLike = bytes | bytearray | memoryview | npt.NDArray[np.uint8]


@dataclass(frozen=True)
class DecodedGraph:
    """A decoded payload and the spark_dsg format version that read it.

    ``version`` is ``"X.Y.Z"``; the installed spark_dsg's own version means ``from_binary``
    read the payload directly, any other value means the versioned-header fallback did.
    ``layer`` is the navigational layer taken.
    """

    snapshot: GraphSnapshot
    version: str
    layer: NavLayer = NavLayer(PLACES_LAYER, 0, "PLACES")  # noqa: RUF009 (frozen: immutable)


@functools.cache
def installed_version() -> str:
    """The spark_dsg version whose binary format ``from_binary`` reads natively (cached: the
    package metadata lookup costs milliseconds and runs once per scene-graph message)."""
    return metadata.version("spark-dsg")


def spark_header(version: str) -> bytes:
    """The 29-byte ``SPARK_DSG`` file header naming ``version`` (``"X.Y.Z"``).

    Layout (verified from a saved ``.sparkdsg``): STR32 "SPARK_DSG", STR32 "main", then the three
    version numbers as UINT8.
    """
    major, minor, patch = _parse_version(version)
    return (
        b"\xdd"
        + (9).to_bytes(4, "little")
        + b"SPARK_DSG"
        + b"\xdd"
        + (4).to_bytes(4, "little")
        + b"main"
        + bytes((0xCC, major, 0xCC, minor, 0xCC, patch))
    )


def _parse_version(version: str) -> tuple[int, int, int]:
    parts = version.strip().split(".")
    try:
        nums = tuple(int(p) for p in parts)
    except ValueError:
        nums = ()
    if len(nums) != 3 or not all(0 <= n <= 255 for n in nums):
        raise MessageDecodeError(
            f"invalid spark_dsg version {version!r}",
            hint="give a version as X.Y.Z, e.g. 1.1.1",
        )
    return nums[0], nums[1], nums[2]


def readable_versions() -> list[str]:
    """The payload versions aion reads, in the order it tries them: the installed spark_dsg's,
    then :data:`FALLBACK_VERSIONS`."""
    native = installed_version()
    return [native, *[v for v in FALLBACK_VERSIONS if v != native]]


def pinned_version(version: str) -> str:
    """``--dsg-version`` checked before any payload is read: one of
    :func:`readable_versions` (a version after the installed spark_dsg's was accepted and
    read as if it were that one, the typo then recorded in the map); a
    :class:`MessageDecodeError` otherwise."""
    _parse_version(version)
    known = readable_versions()
    if version.strip() not in known:
        raise MessageDecodeError(
            f"--dsg-version {version.strip()}: aion reads scene-graph payloads of spark_dsg "
            f"{', '.join(known)} (the first is the installed spark_dsg's)",
            hint="leave out --dsg-version: each log's version is found from its payloads",
        )
    return version.strip()


def _as_bytes(payload: PayloadLike) -> bytes:
    """spark_dsg's ``from_binary`` accepts only ``bytes``; rosbags hands out uint8 arrays."""
    if isinstance(payload, bytes):
        return payload
    if isinstance(payload, np.ndarray):
        return np.ascontiguousarray(payload, dtype=np.uint8).tobytes()
    return bytes(payload)


def _candidate_versions(payload: bytes) -> list[str]:
    """Versions to try, most likely first.

    Byte 5 of a payload is the type tag of the first layer entry: an array (0xdd, a layer key)
    from 1.1.2 on, an INT64 (0xd3, a layer id) before. Versions of the other family are still
    tried, last, in case the sniff is fooled.
    """
    ordered = readable_versions()
    if len(payload) > 5 and payload[5] == 0xD3:
        early = [v for v in ordered if _parse_version(v) <= (1, 1, 1)]
        return early + [v for v in ordered if v not in early]
    return ordered


def _native_output_silenced() -> contextlib.AbstractContextManager[None]:
    """stdout and stderr to /dev/null for the block
    (:func:`formats.native_output.native_output_silenced`): spark_dsg's C++ logger prints
    "Loading file with outdated encoding" on *stdout* for every load of an older version, which
    would corrupt ``--format json`` output; aion reports the version it used instead."""
    from aion_cli.formats.native_output import native_output_silenced

    return native_output_silenced()


def _load_with_header(payload: bytes, version: str) -> Any:
    """``DynamicSceneGraph.load`` of ``header(version) + payload`` via a temporary file."""
    import spark_dsg

    from aion_cli.formats.interrupts import interrupts_held

    name: str | None = None
    try:
        with interrupts_held():  # created and named, or neither (a Ctrl-C between leaked it)
            fd, name = tempfile.mkstemp(suffix=".sparkdsg", prefix="aion-dsg-")
            handle = os.fdopen(fd, "wb")
        with handle as fh:
            fh.write(spark_header(version))
            fh.write(payload)
        with _native_output_silenced(), _memory_budget(len(payload)):
            return spark_dsg.DynamicSceneGraph.load(name)
    finally:
        if name is not None:
            with contextlib.suppress(OSError):
                os.unlink(name)


def read_dsg_payload(payload: PayloadLike, version: str | None = None) -> tuple[Any, str]:
    """Decode a DsgUpdate payload into a spark_dsg graph; return ``(graph, version)``.

    ``version`` pins one format version (no fallback). Undecodable payloads raise
    :class:`MessageDecodeError` listing every version tried and its error.
    """
    import spark_dsg

    data = _as_bytes(payload)
    native = installed_version()
    versions = [version.strip()] if version is not None else _candidate_versions(data)
    if version is not None:
        _parse_version(version)
    failures: list[str] = []
    for v in versions:
        try:
            if v == native:
                with _memory_budget(len(data)):
                    graph = spark_dsg.DynamicSceneGraph.from_binary(data)
            else:
                graph = _load_with_header(data, v)
        except (ValueError, RuntimeError, IndexError, TypeError, MemoryError) as exc:
            # MemoryError: std::bad_alloc when a damaged length field asks for gigabytes
            # (past the _memory_budget of the parse)
            why = _short(exc)
            if isinstance(exc, MemoryError) or "bad_alloc" in why:
                why = "asks for more memory than a payload of its size may take (a damaged length?)"
            failures.append(f"{v}: {why}")
            continue
        return graph, v
    raise MessageDecodeError(
        f"cannot decode scene-graph payload ({len(data)} bytes); versions tried: "
        + "; ".join(failures),
        hint="the payload may be truncated or from spark_dsg < 1.0.2; "
        "pin a version with --dsg-version if you know it"
        if version is None
        else f"--dsg-version {version.strip()} does not read it: leave the option out, and "
        f"the version is found from the payload ({', '.join(readable_versions())} are tried)",
    )


def _short(exc: Exception) -> str:
    """The first line of an error, whitespace runs collapsed, at most 120 characters."""
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return " ".join(text.split())[:120]


def decode_dsg(
    payload: PayloadLike,
    t_ns: int,
    version: str | None = None,
    layer: str | int | None = None,
    fast: bool = True,
    reader: GraphReader | None = None,
) -> DecodedGraph:
    """Decode a payload to a snapshot at ``t_ns`` and say which format version read it.

    ``fast`` (the default): a payload in the layout of the installed spark_dsg's own version
    (when that is the one :mod:`formats.dsg_binary` reads, and ``version`` asks for no
    other) is read from its bytes with numpy (:func:`formats.dsg_fast.fast_navigation`),
    ~10x faster; spark_dsg decodes whatever that reader does not vouch for, so the result
    is the same either way. ``reader``: a stream's :class:`formats.dsg_delta.GraphReader`
    (the numpy reader re-reads only the node records changed since its last payload)."""
    if fast and _fast_applies(version):
        from aion_cli.formats.dsg_fast import fast_navigation

        nav = fast_navigation(payload, t_ns, layer, reader)
        if nav is not None:
            return DecodedGraph(nav.snapshot, installed_version(), nav.layer)
    graph, used = read_dsg_payload(payload, version)
    try:
        nav = navigation(graph, t_ns, layer)
    except UnicodeDecodeError as exc:  # spark_dsg reads a damaged node name without checking
        raise MessageDecodeError(
            f"scene-graph payload ({len(_as_bytes(payload))} bytes) holds a node name that is "
            f"not UTF-8 ({exc.reason} at byte {exc.start})",
            hint="the payload is damaged",
        ) from exc
    return DecodedGraph(nav.snapshot, used, nav.layer)


def _fast_applies(version: str | None) -> bool:
    """Whether the numpy reader reads payloads as spark_dsg would here: the installed
    spark_dsg reads payloads in the layout of :data:`formats.dsg_binary.BINARY_VERSION`, and
    no other version is asked for."""
    from aion_cli.formats.dsg_binary import BINARY_VERSION

    native = installed_version()
    return native == BINARY_VERSION and (version is None or version.strip() == native)


def decode_dsg_update(
    payload: PayloadLike, t_ns: int, version: str | None = None, layer: str | int | None = None
) -> GraphSnapshot:
    """Decode a ``hydra_msgs/DsgUpdate.layer_contents`` payload into a :class:`GraphSnapshot`.

    Hydra always sends the whole graph (``full_update = true``), so each message is decoded on its
    own. Use :func:`decode_dsg` to also learn the payload version.
    """
    return decode_dsg(payload, t_ns, version, layer).snapshot
