"""Decoding with the definitions a log embeds: the rosbags typestore that knows a message type as
the log defines it (:func:`_store_with_definition`; aion's shipped definitions of
:mod:`formats.msgdefs` when the log embeds none), a private store when the log's definition
conflicts with the standard one, and the parsing of embedded ``.msg`` / IDL text
(:func:`_parse_definition`). :class:`formats.logs.LogSet` decodes through these.
"""

from __future__ import annotations

import copy
import re
from functools import lru_cache
from typing import TYPE_CHECKING, Any

from aion_cli.errors import NO_DEFINITION_HINT, MessageDecodeError, MissingDefinitionError

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore


#: the member rosbags gives a type without fields (an IDL struct needs one)
_PLACEHOLDER = "structure_needs_at_least_one_member"
_SEPARATOR = re.compile(r"^={3,}[ \t]*$", re.MULTILINE)
#: rosbags field-definition node kinds: a message, a fixed array, a sequence
_NAME, _ARRAY, _SEQUENCE = 2, 3, 4


def _store_with_definition(
    stores: dict[str, Typestore], encoding: str, msgtype: str, definition: str, idl: bool
) -> Typestore:
    """A typestore that knows ``msgtype`` as ``definition`` defines it: the set's shared store
    for ``encoding``, or a private one when the log's definition conflicts with it."""
    from rosbags.typesys.base import TypesysError

    from aion_cli.formats import msgdefs

    ros_version = 1 if encoding == "ros1" else 2
    if not definition.strip():
        shipped = msgdefs.typestore(ros_version)
        if msgtype in shipped.fielddefs:
            return shipped
        raise MissingDefinitionError(
            f"the log has no definition for {msgtype} and aion ships none",
            hint=NO_DEFINITION_HINT,
        )
    types = _parse_definition(definition, msgtype, idl)
    _check_fields(types, msgtype, ros_version, idl)
    store = stores.get(encoding)
    if store is None:
        store = stores[encoding] = msgdefs.base_typestore(ros_version)
    try:
        store.register(types)
    except TypesysError:
        # The log's own version of a type differs from the standard one: decode this topic with
        # a store holding only the log's definitions (plus the builtin time types they use).
        from rosbags.typesys.store import Typestore

        private = Typestore()
        builtins = {k: v for k, v in store.fielddefs.items() if k.startswith("builtin_interfaces/")}
        private.register({**builtins, **types})
        store = private
    _check_complete(store, msgtype, types)
    return store


def _check_complete(store: Typestore, msgtype: str, types: dict[str, Any]) -> None:
    """Refuse a definition that uses a type neither it nor the store defines (a ROS 1 text
    writing ``Point`` for ``geometry_msgs/Point``, which means ``pkg/Point`` of its own
    package; a ``MSG:`` block missing): rosbags registers it, and every later look-up of the
    type failed as an internal ``KeyError``."""
    from aion_cli.formats.raw import normalize_msgtype

    name = msgtype if msgtype in store.fielddefs else normalize_msgtype(msgtype)
    todo, seen = [name], set()
    while todo:
        current = todo.pop()
        if current in seen:
            continue
        seen.add(current)
        if current not in store.fielddefs:
            raise MessageDecodeError(
                f"the log's definition of {msgtype} uses {current}, which it does not define",
                hint="its embedded definition lacks the MSG: block of that type (in ROS 1 a type "
                "of another package is written with its package: geometry_msgs/Point)",
            )
        for _, (kind, detail) in store.fielddefs[current][1]:
            node = detail[0] if kind in (_ARRAY, _SEQUENCE) else (kind, detail)  # the element
            if int(node[0]) == _NAME:
                todo.append(str(node[1]))


def _parse_definition(definition: str, msgtype: str, idl: bool) -> dict[str, Any]:
    """The types ``definition`` defines (a new dict each call). A log with thousands of topics
    of one type embeds the same text for each: it is parsed once (rosbags' parser takes
    ~15 ms per definition)."""
    return copy.deepcopy(_parsed(definition, msgtype, idl))


@lru_cache(maxsize=256)
def _parsed(definition: str, msgtype: str, idl: bool) -> dict[str, Any]:
    from rosbags.typesys import get_types_from_idl, get_types_from_msg

    if not idl:
        # rosbags wants the 80-character separator; ROS tools accept any run of "=".
        definition = _SEPARATOR.sub("=" * 80, definition)
    try:
        if idl:
            return dict(get_types_from_idl(definition))
        return dict(get_types_from_msg(definition, msgtype))
    except Exception as exc:  # rosbags parser errors
        raise MessageDecodeError(
            f"cannot parse the log's definition of {msgtype} ({exc})",
            hint="the log's embedded message definition is malformed",
        ) from exc


def _check_fields(types: dict[str, Any], msgtype: str, ros_version: int, idl: bool) -> None:
    """Refuse a log's definition that gives ``msgtype`` no field (a text of comments only)
    where aion's own definition has fields: decoded with it, every message failed as "CDR
    message size mismatch", which named neither the definition nor what is wrong with it."""
    from aion_cli.formats.msg_layouts import shipped_layout
    from aion_cli.formats.msgdefs import UnknownMessageTypeError
    from aion_cli.formats.raw import normalize_msgtype

    entry = types.get(msgtype) or types.get(normalize_msgtype(msgtype))
    if entry is None or entry[1]:
        return
    try:
        layout = shipped_layout(msgtype, ros_version)
    except UnknownMessageTypeError:  # a type aion does not ship
        return
    # (rosbags gives a type without fields, std_msgs/Empty, the one IDL requires of a struct)
    shipped = sum(name != _PLACEHOLDER for name, _ in layout)
    if shipped:
        raise MessageDecodeError(
            f"the log's definition of {msgtype} is empty: its {'IDL' if idl else '.msg'} "
            f"text gives it no field, only comments (aion's own definition of {msgtype} has "
            f"{shipped} fields), so its messages cannot be decoded with it",
            hint="the recorder did not have the message package's definition: record with "
            f"the package that defines {msgtype} installed (a log that embeds no definition "
            "text at all is read with aion's own)",
        )
