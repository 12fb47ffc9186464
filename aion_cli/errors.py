"""Typed errors shared by every layer.

Library code raises these; only ``aion_cli.cli`` turns them into a one-line ``error: ...`` with
a hint. :class:`InputError` and its subclasses are the user's to fix (exit code 2); any other
:class:`AionError` is an internal fault (exit code 1).
"""

from __future__ import annotations

import shlex
from os import PathLike
from typing import Any


class AionError(Exception):
    """Base of every error aion raises on purpose.

    ``hint`` says what the user can do about it; the CLI prints it under the error line.
    """

    def __init__(self, message: str, hint: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.hint = hint

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled whole (message, hint and any field of a subclass), whatever the subclass's
        constructor: errors of a parallel build's workers reach the parent intact."""
        return (_rebuild_error, (type(self), self.args, self.__dict__))


def _rebuild_error(cls: type[AionError], args: tuple[Any, ...], fields: dict[str, Any]) -> Any:
    error = cls.__new__(cls)
    error.args = args
    error.__dict__.update(fields)
    return error


def path_word(path: str | PathLike[str]) -> str:
    """``path`` as one word of a command a hint or note tells the user to run, quoted as a
    shell needs it (``'my logs/day 1.mcap'``; a plain path is unchanged). Give it the path as
    the user gave it, not its bare name: the command then works from where they ran aion
    (a name alone names a file of the current folder)."""
    return shlex.quote(str(path))


class MissingSystemLibraryError(AionError):
    """A library the machine must provide is missing (e.g. open3d's ``libusb-1.0.so.0``): not
    a bug in aion and not bad input; the hint names the package that provides it (exit 1)."""


class MissingPackageError(AionError):
    """An optional part of aion is not installed (e.g. open3d for ``aion export``, the
    ``export`` extra); the hint names the pip command (exit 1)."""


class InputError(AionError):
    """Bad input or usage: a file, an option, a value the user gave (CLI exit code 2)."""


class UnknownArgumentError(InputError, TypeError):
    """A keyword argument a function of the Python API does not take (``aion.build(logs,
    bogus=1)``), or more positional ones than it takes (``m.predict(time, "UTC")``): an
    :class:`InputError` with a hint listing the keywords it does take, as every
    refused argument is, and a ``TypeError``, as Python raises for an unknown keyword (code
    that catches ``TypeError`` still does)."""


class ConfigError(InputError):
    """A model parameter or configuration file is invalid."""


class CoordinateRangeError(InputError):
    """A coordinate cannot be packed into a spatial-hash key (too large or not finite)."""


class LogFormatError(InputError):
    """A log file cannot be opened or read (unknown format, corrupt, empty)."""


class StaleIndexError(AionError):
    """Log times taken from a container's index are not those of the messages its stream
    yields: a chunk the index vouched for cannot be read after all (a CRC or decompression
    failure only reading it shows). Raised by the readers when they meet such a chunk; the
    build (``pipeline._Build.learn``) starts over reading the logs in full, so the user never
    sees it."""


class TopicNotFoundError(InputError):
    """No usable topic, or the named topic is missing; ``candidates`` lists what the log has."""

    def __init__(
        self, message: str, candidates: list[str] | None = None, hint: str | None = None
    ) -> None:
        super().__init__(message, hint)
        self.candidates = candidates or []


class MessageDecodeError(InputError):
    """A message payload cannot be decoded (wrong type, truncated, unknown version)."""


class MissingDefinitionError(MessageDecodeError):
    """The log carries no definition of a message type and aion ships none (a rosbag2 of
    sqlite3 storage recorded by ROS 2 Humble or earlier records none): nothing, not even a
    TOML mapping, can decode its messages."""


NO_DEFINITION_HINT = (
    "the log records no message definitions (as rosbag2 bags of sqlite3 storage from ROS 2 "
    "Humble and earlier do): record with `ros2 bag record -s mcap`, which stores them, or "
    "convert the bag to MCAP storage with `ros2 bag convert` in a shell where the type's "
    "package is sourced"
)
"""What to do about a :class:`MissingDefinitionError`."""


class PartialGraphError(InputError):
    """A scene-graph message holds part of a graph (a ``hydra_msgs/DsgUpdate`` whose
    ``full_update`` is false), which would read as a graph without the rest of its nodes."""


class TransformError(InputError):
    """A frame transform is missing or outside the recorded time range."""


class MapFileError(InputError):
    """A map file is invalid: not a map, corrupted, or from an unsupported version."""


class PartMapError(MapFileError):
    """A part map (``aion build --part``) holds days not yet scored: it forecasts nothing
    until ``aion merge`` joins it with the parts before it."""


class MapCorruptError(MapFileError):
    """A map member fails its checksum or cannot be parsed."""


MAP_REBUILD_HINT = "the map was damaged or not written by aion; rebuild it with `aion build`"
"""The hint of a map whose members pass their checksums but do not make a valid state."""


class MapVersionError(MapFileError):
    """A map file was written by a newer, incompatible aion."""


class OutputLockedError(InputError):
    """Another process is writing the same output (a log, an export): its lock is held."""


class MapLockedError(OutputLockedError):
    """Another process is writing the same map file."""


class UnknownNodeError(InputError):
    """A node id given by the user does not exist in the map."""


class NoPathError(InputError):
    """Start and goal are not connected in the navigational graph."""


class AionWarning(UserWarning):
    """What the CLI prints as ``warning: ...`` (a build's or a merge's ``report.warnings``),
    issued by the Python API with :func:`warnings.warn` so that a script or a notebook shows
    it: the map was made, but from less than the input held (a truncated log ...)."""
