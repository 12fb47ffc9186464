"""Output paths of :class:`formats.writers.LogWriter`: whether a path is a log aion may
replace (:func:`is_own_log`, :func:`is_own_rosbag2`) and the check run before anything is
written (:func:`check_log_target`), with the errors a refused log raises.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from aion_cli.errors import LogFormatError
from aion_cli.formats.outputs import (
    OutputPathError,
    check_output,
    file_starts_with,
    folder_entries,
)


class LogWriteError(LogFormatError):
    """A log cannot be created (existing path, unknown container)."""


class LogTargetError(LogWriteError, OutputPathError):
    """The output path is refused: special file, current folder, exists, or not aion's log."""


MCAP_MAGIC = b"\x89MCAP0\r\n"
BAG_MAGIC = b"#ROSBAG V2.0\n"
#: the caller id of every connection of a ROS 1 bag aion writes (a recording names its
#: recorder's node), and the ``custom_data`` entry of a rosbag2 folder's metadata.yaml
AION_CALLERID = "/aion"
AION_ROSBAG2_MARK = ("writer", "aion")
_MAX_METADATA_BYTES = 16 * 1024**2


def is_own_log(path: Path, container: str) -> bool:
    """True when ``path`` is a log of ``container``'s kind that ``--force`` may replace: an MCAP
    file whose header names aion as its library (what :class:`LogWriter` writes; a robot's
    recording names its recorder) for ``mcap`` / ``mcap-ros1``, a ROS 1 bag whose every
    connection has aion's caller id (:data:`AION_CALLERID`; a recording's name the nodes
    that published) for ``bag``, and for the rosbag2 containers a folder holding only
    ``metadata.yaml`` (whose ``custom_data`` carries :data:`AION_ROSBAG2_MARK`) and the
    storage files it names (no other file, no subfolder), as :class:`LogWriter` writes it.
    Bags and rosbag2 folders aion wrote before 2026-12-06 carry no mark: they are refused."""
    if container in ("mcap", "mcap-ros1"):
        from aion_cli.formats.scene_mcap import library_of

        header = library_of(path)
        return header is not None and header[1].split(" ")[0] == "aion"
    if container == "bag":
        return file_starts_with(path, BAG_MAGIC) and _aion_bag(path)
    return is_own_rosbag2(path)


def _aion_bag(path: Path) -> bool:
    """Whether every connection of the ROS 1 bag at ``path`` has aion's caller id (an
    unreadable bag is not aion's)."""
    try:
        from rosbags.rosbag1 import Reader

        with Reader(path) as reader:
            callers = [getattr(c.ext, "callerid", None) for c in reader.connections]
    except Exception:  # damaged, truncated, unindexed: not one aion wrote
        return False
    return bool(callers) and all(c == AION_CALLERID for c in callers)


def is_own_rosbag2(path: Path) -> bool:
    """A rosbag2 folder of ``metadata.yaml`` marked as aion's plus exactly the storage files
    it names (see :func:`is_own_log`); anything else in it (a CSV, a subfolder, a symlink),
    or no mark, says no."""
    names = folder_entries(path)
    if names is None or "metadata.yaml" not in names:
        return False
    meta = path / "metadata.yaml"
    try:
        st = os.lstat(meta)
        if not stat.S_ISREG(st.st_mode) or st.st_size > _MAX_METADATA_BYTES:
            return False
        from ruamel.yaml import YAML  # rosbags' own YAML library

        doc = YAML(typ="safe").load(meta.read_text(encoding="utf-8"))
        info = doc["rosbag2_bagfile_information"]
        files = info["relative_file_paths"]
        key, value = AION_ROSBAG2_MARK
        if (info.get("custom_data") or {}).get(key) != value:
            return False  # a recording (ros2 bag record writes no such mark)
    except Exception:  # unreadable, not YAML, not rosbag2 metadata: not ours
        return False
    if not isinstance(files, list) or not all(isinstance(f, str) and f for f in files):
        return False
    allowed = {"metadata.yaml", *files}
    if any("/" in f or f in (".", "..") for f in files) or set(names) - allowed:
        return False
    for name in names:
        try:
            if not stat.S_ISREG(os.lstat(path / name).st_mode):
                return False
        except OSError:
            return False
    return True


def _log_kind(container: str) -> str:
    if container in ("mcap", "mcap-ros1"):
        return "an MCAP log"
    if container == "bag":
        return "a ROS 1 bag"
    return "a rosbag2 folder"


def check_log_target(path: str | os.PathLike[str], container: str, *, overwrite: bool) -> bool:
    """Refuse an output path before anything is written (see :mod:`formats.outputs`): a device,
    FIFO or socket, the current folder, an existing path without ``overwrite``, or an existing
    path that is not a log of ``container``'s kind (:func:`is_own_log`). Returns whether an
    existing log will be replaced. Raises :class:`LogTargetError` (exit 2)."""
    try:
        return check_output(
            path,
            overwrite=overwrite,
            recognise=lambda p: is_own_log(p, container),
            what=_log_kind(container),
            folder=container.startswith("rosbag2"),
        )
    except OutputPathError as exc:
        raise LogTargetError(exc.message, exc.hint) from None
