"""Comparing a log's message definition with the layout a fast decoder was written for.

A :data:`Layout` is a message's fields with type names, comments, spacing and constants left
out: :func:`shipped_layout` gives it for the definitions aion ships (:mod:`formats.msgdefs`),
:func:`definition_layout` for a log's own text, and :func:`same_layout` tells whether the two
agree (the numpy fast decoders read only logs whose layout is the shipped one).
"""

from __future__ import annotations

from typing import Any

from aion_cli.formats.msgdefs import UnknownMessageTypeError, _check_version, typestore
from aion_cli.formats.raw import normalize_msgtype

#: A message layout with type names left out: per field ``(name, node)``, a node being
#: ``("base", type, bound)``, ``("msg", layout)``, ``("array", node, length)`` or
#: ``("sequence", node, bound)``. Two definitions with equal layouts have the same wire format
#: and the same field names, whatever their comments, spacing, constants or type names.
Layout = tuple[tuple[str, tuple[Any, ...]], ...]

_NODE_KINDS = {1: "base", 2: "msg", 3: "array", 4: "sequence"}


class _UnresolvedError(Exception):
    """A field refers to a type that neither the definition nor the base store defines."""


def _node(kind_detail: Any, lookup: dict[str, Any], depth: int) -> tuple[Any, ...]:
    """One rosbags field node (``(Nodetype, detail)``) as a layout node."""
    kind = _NODE_KINDS.get(int(kind_detail[0]))
    detail = kind_detail[1]
    if kind == "base":
        return ("base", str(detail[0]), int(detail[1]))
    if kind == "msg":
        return ("msg", _layout(str(detail), lookup, depth + 1))
    if kind in ("array", "sequence"):
        return (kind, _node(detail[0], lookup, depth), int(detail[1]))
    raise _UnresolvedError(f"unknown field node {kind_detail!r}")


def _layout(msgtype: str, lookup: dict[str, Any], depth: int = 0) -> Layout:
    """The layout of ``msgtype`` from rosbags field definitions (``name -> (consts,
    fields)``), every sub-message resolved in ``lookup``."""
    if depth > 32:
        raise _UnresolvedError(f"{msgtype} nests too deeply (a recursive definition?)")
    entry = lookup.get(msgtype)
    if entry is None:
        raise _UnresolvedError(f"{msgtype} is not defined")
    return tuple((str(name), _node(node, lookup, depth)) for name, node in entry[1])


def shipped_layout(msgtype: str, ros_version: int) -> Layout:
    """The layout of ``msgtype`` as aion ships it for ROS ``ros_version`` (what the numpy fast
    decoders were written for); :class:`UnknownMessageTypeError` if aion has no definition."""
    version = _check_version(ros_version)
    name = normalize_msgtype(msgtype)
    store = typestore(version)
    try:
        return _layout(name, dict(store.fielddefs))
    except _UnresolvedError as exc:
        raise UnknownMessageTypeError(
            f"no ROS {version} definition for message type {name!r} ({exc})"
        ) from exc


def definition_layout(
    definition: str, msgtype: str, ros_version: int, idl: bool = False
) -> Layout | None:
    """The layout of ``msgtype`` as a log's own ``definition`` text describes it (``.msg`` text
    with ``MSG:`` blocks for the sub-messages, or ROS 2 IDL), sub-messages the text leaves out
    taken from aion's base store of ``ros_version``. None when the text cannot be parsed or
    leaves a type undefined."""
    from aion_cli.errors import MessageDecodeError
    from aion_cli.formats.typestores import _parse_definition

    name = normalize_msgtype(msgtype)
    try:
        parsed = _parse_definition(definition, name, idl)
    except MessageDecodeError:
        return None
    lookup: dict[str, Any] = dict(typestore(_check_version(ros_version)).fielddefs)
    lookup.update({normalize_msgtype(k): v for k, v in parsed.items()})
    try:
        return _layout(name, lookup)
    except _UnresolvedError:
        return None


def same_layout(
    definition: str,
    msgtype: str,
    ros_version: int,
    idl: bool = False,
    reference: str | None = None,
) -> bool:
    """Whether a log's ``definition`` of ``msgtype`` has the layout aion ships for
    ``reference`` (default ``msgtype``): same fields, names, types, array lengths and nested
    messages, after stripping comments, whitespace and constants and resolving every
    sub-message. An empty definition (old rosbag2 files carry none) counts as the shipped one;
    a definition that cannot be parsed does not match."""
    if not definition.strip():
        return True
    mine = definition_layout(definition, msgtype, ros_version, idl)
    if mine is None:
        return False
    try:
        return mine == shipped_layout(reference or msgtype, ros_version)
    except UnknownMessageTypeError:
        return False
