"""Output paths that never lose data: what may be replaced, and writing beside the target.

Every file or folder aion writes (logs from ``convert`` / ``simulate``, maps, exports, ground
truth) follows the same three rules, so that no option, typo or interruption can destroy data:

1. **Special files are refused before anything is written.** A target that exists and is a
   character or block device (``/dev/null``), a FIFO, a socket, or the current folder (``-o .``)
   or one of its parents is an :class:`OutputPathError` (exit 2), and so is a target whose
   folder does not exist (:func:`check_output_folder`: aion makes no folders above an output).
   Symbolic links are judged by what they point to; replacing one replaces the link, never the
   file it points to.
2. **Only aion's own outputs are replaced.** An existing target is replaced only when the caller
   allows it (``--force``) *and* the caller's recogniser says it is an output of that kind
   (an MCAP file by its magic bytes, a rosbag2 folder holding only ``metadata.yaml`` and the
   storage files it names, a map by its manifest...). Anything else, a folder holding other
   files in particular, is refused with the reason. A 0-byte regular file (and, where the
   output is a folder, an empty folder) holds no data and counts as replaceable.
   Commands that replace their own outputs without ``--force`` (``export``, ``report``,
   maps) apply the same recognisers; a folder written *into* (``export -o DIR``) replaces
   only same-named files its recogniser accepts (:class:`Staged` ``recognise``).
3. **Outputs appear complete or not at all.** :class:`Staged` writes into a hidden folder
   ``.<name>.<random>.tmp`` beside the target and renames the result into place when it is
   complete: an exception (disk full, Ctrl-C, a bad record) leaves the previous output as it
   was and removes the staging folder. Replacing a file is one atomic ``rename``; replacing a
   folder is two (old out of the way, new in), with the old one put back if the second fails.
   Writers whose library does not report errors (open3d, spark_dsg) check the staged file
   before it is committed.

Only a SIGKILL leaves a staging folder behind (nothing can run then); its name starts with a
dot and the target's name, so it is easy to recognise and delete. Hidden and lock names keep
within the 255 bytes a file name may have: a long target name is cut and ends in ``~`` and 8
hex digits of its hash (:func:`fitted_name`).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from aion_cli.errors import InputError, path_word
from aion_cli.formats.committed import note_committed
from aion_cli.formats.interrupts import interrupts_held

Recogniser = Callable[[Path], bool]
"""Says whether an existing path is an output the caller may replace (follows symlinks)."""

_SPECIAL = (
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
)


NAME_MAX = 255
"""Bytes a file name may have on the file systems aion writes to (ext4, xfs, btrfs, tmpfs)."""

STAGING_ROOM = 14
"""Bytes a hidden staging name adds to its target's name: ``.`` + ``.`` + 8 random + ``.tmp``."""


class OutputPathError(InputError):
    """An output path aion refuses to write or replace (exit 2); nothing was written."""


def fitted_name(name: str, room: int) -> str:
    """``name`` when it and ``room`` more bytes fit in a file name (:data:`NAME_MAX`), else
    its longest leading part that does, then ``~`` and 8 hex digits of the whole name's hash:
    the hidden staging and lock names of a legal 255-byte target stay legal, start like it
    and differ between targets that share a long beginning."""
    raw = os.fsencode(name)
    if len(raw) + room <= NAME_MAX:
        return name
    tag = "~" + hashlib.sha256(raw).hexdigest()[:8]
    keep = name[: NAME_MAX - room - len(tag)]
    while keep and len(os.fsencode(keep)) + len(tag) + room > NAME_MAX:
        keep = keep[:-1]  # a multi-byte character (or an undecodable byte) at the end
    return keep + tag


def staging_prefix(name: str) -> str:
    """The start of a hidden temporary name beside the target ``name`` (``.<name>.``; a
    random part and ``.tmp`` follow): the whole is a legal file name."""
    return f".{fitted_name(name, STAGING_ROOM)}."


_STAGED_NAME = re.compile(r"\.(.+)\.(?:[a-z0-9_]{8}|[0-9]+)\.tmp")


def staged_target(name: str) -> str | None:
    """The target a hidden staging name (:func:`staging_prefix`, then mkdtemp's or mkstemp's
    8 random characters or the API's process id, and ``.tmp``) stands for, as fitted (a long
    one cut, ``~`` and its hash); None for any other name (a ``.x.y.tmp`` of the user's)."""
    staged = _STAGED_NAME.fullmatch(name)
    return None if staged is None else staged.group(1)


def plain_text(text: object) -> str:
    """``text`` (a name from a map, a log or a scene graph) as literal matplotlib text:
    :func:`safe_text`, its ``$`` escaped (``cost$1$.aion`` is not read as mathematics)."""
    return safe_text(text).replace("$", r"\$")


def safe_text(name: object) -> str:
    """A file name (a path, bytes or text holding one) as text every encoder accepts: a
    name's bytes that are not UTF-8 (``map\\xff.aion``) become U+FFFD. For names written into
    an output's content (a picture's title, JSON, an MCAP record, a web page), which must be
    UTF-8 where the file system's names need not be."""
    if isinstance(name, str | bytes | os.PathLike):
        text = os.fsdecode(name)
    else:
        text = str(name)
    # a lone surrogate that stands for no undecodable byte (from JSON, say) is replaced
    # first, so that the escaped bytes still become U+FFFD and not "?"
    text = _LONE_SURROGATE.sub("\ufffd", text)
    return text.encode("utf-8", "surrogateescape").decode("utf-8", "replace")


_LONE_SURROGATE = re.compile("[\ud800-\udc7f\udd00-\udfff]")
"""Surrogates that ``surrogateescape`` did not make (it makes U+DC80..U+DCFF, one per byte)."""


def special_kind(path: Path) -> str | None:
    """``"a character device"`` etc. when ``path`` (followed) exists and is not a regular file
    or folder; ``None`` otherwise (missing, regular file, folder, dangling link)."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    for test, name in _SPECIAL:
        if test(mode):
            return name
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        return "not a regular file"
    return None


def _exists(path: Path) -> bool:
    """True for anything at ``path``, a dangling symlink included."""
    return os.path.lexists(path)


def refuse_current_folder(target: Path, example: str) -> None:
    """:class:`OutputPathError` when ``target`` is the current folder or one of its parents
    (``-o .``): an output is named inside it, never the folder itself (``example``: the
    name the hint suggests, e.g. ``out.mcap``)."""
    if _is_cwd_or_parent(target):
        raise OutputPathError(
            f"{target} is the current folder (or one of its parents): aion does not write "
            "into it as an output of its own",
            hint=f"name an output inside it, e.g. {example}",
        )


def check_output_folder(
    target: str | os.PathLike[str],
    named: str | None = None,
    error: type[InputError] = OutputPathError,
) -> None:
    """``error`` (exit 2) unless the folder ``target`` goes into exists. aion never makes
    the folders above an output: a mistyped ``-o`` would leave the output where nobody looks
    (an output that is itself a folder, ``export -o DIR``, is made). ``named``: the output as
    the message names it (``--png x.png``; default ``target``)."""
    path = Path(target)
    folder = path.parent
    if folder.is_dir():
        return
    if os.path.lexists(folder):
        raise error(
            f"cannot write {named or path}: {folder} is a file, not a folder",
            hint="choose a path whose folders are folders",
        )
    raise error(
        f"cannot write {named or path}: the folder {folder} does not exist",
        hint=f"create it first (mkdir -p {path_word(folder)}) or choose another path",
    )


def _is_cwd_or_parent(path: Path) -> bool:
    try:
        target = path.resolve()
        cwd = Path.cwd().resolve()
    except (OSError, RuntimeError):
        return False
    return target == cwd or target in cwd.parents


def is_empty_file(path: Path) -> bool:
    """A regular file of 0 bytes (nothing to lose by replacing it)."""
    try:
        st = os.stat(path)
    except OSError:
        return False
    return stat.S_ISREG(st.st_mode) and st.st_size == 0


def is_empty_folder(path: Path) -> bool:
    """A real folder (not a link) with nothing in it (nothing to lose by replacing it)."""
    return path.is_dir() and not path.is_symlink() and folder_entries(path, 1) == []


def file_starts_with(path: Path, magic: bytes) -> bool:
    """A regular file whose first bytes are ``magic`` (reads ``len(magic)`` bytes only)."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return False
        with open(path, "rb") as fh:
            return fh.read(len(magic)) == magic
    except OSError:
        return False


def folder_entries(path: Path, limit: int = 10_000) -> list[str] | None:
    """Names in a folder (at most ``limit``; None if it cannot be listed)."""
    try:
        with os.scandir(path) as it:
            names = []
            for entry in it:
                names.append(entry.name)
                if len(names) > limit:
                    break
            return names
    except OSError:
        return None


def check_output(
    path: str | os.PathLike[str],
    *,
    overwrite: bool,
    recognise: Recogniser,
    what: str,
    folder: bool = False,
    option: str | None = "--force",
) -> bool:
    """Validate the output target ``path`` before anything is written.

    Returns whether an existing target will be replaced (True) or the path is free (False).
    Raises :class:`OutputPathError` for a special file, the current folder or a parent of it,
    an existing target without ``overwrite``, and an existing target that ``recognise`` does not
    accept as ``what`` (e.g. ``"an MCAP log"``). ``folder``: the output is a folder (a rosbag2
    bag), which changes only the wording of the refusal. ``option``: what lets the user replace
    an output (``--force``), or None for a command that replaces its own outputs unasked
    (``export``): the hints name only options the command has.
    """
    target = Path(path)
    kind = special_kind(target)
    if kind is not None:
        raise OutputPathError(
            f"{target} is {kind}, not a {'folder' if folder else 'regular file'}: aion "
            "does not write to it",
            hint="choose a path for a new file (or one aion wrote)",
        )
    refuse_current_folder(target, "out.mcap")
    check_output_folder(target)
    if not _exists(target):
        return False
    if not overwrite:
        raise OutputPathError(
            f"{target} exists already",
            hint=f"remove it, choose another path, or add {option or '--force'} (which "
            f"replaces only {what} aion wrote)",
        )
    if is_empty_file(target) or (folder and is_empty_folder(target)) or recognise(target):
        return True
    raise OutputPathError(
        f"{target} exists and is {_what_it_is(target)}, not {what} aion wrote: refusing to "
        "replace it",
        hint=refusal_hint(option),
    )


def refusal_hint(option: str | None = "--force") -> str:
    """The hint under a refusal to replace something aion did not write."""
    lead = (
        f"{option} replaces only aion's own outputs"
        if option
        else "aion replaces only files it wrote itself"
    )
    return f"{lead}; choose another path or remove it yourself"


def _what_it_is(path: Path) -> str:
    """A short description of an existing path for refusals (what would have been lost)."""
    if os.path.islink(path) and not os.path.exists(path):
        return "a dangling symbolic link"
    if path.is_dir():
        names = folder_entries(path, 50)
        if names is None:
            return "a folder aion cannot list"
        if not names:
            return "an empty folder"
        shown = ", ".join(sorted(names)[:5]) + (", ..." if len(names) > 5 else "")
        return f"a folder holding {len(names)}{'+' if len(names) > 50 else ''} item(s) ({shown})"
    return "another file"


def fsync_dir(folder: Path) -> None:
    """Make a rename durable; best effort (some filesystems refuse to open folders)."""
    _fsync_file(folder)


def _fsync_tree(path: Path) -> None:
    """fsync a written file, or every file of a written folder."""
    if path.is_dir() and not path.is_symlink():
        for root, _dirs, files in os.walk(path):
            for name in files:
                _fsync_file(Path(root) / name)
    else:
        _fsync_file(path)


def _fsync_file(path: Path) -> None:
    """fsync one file or folder; best effort (an error is ignored)."""
    with contextlib.suppress(OSError):
        fd = os.open(path, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


@contextlib.contextmanager
def cannot_write(out: Path) -> Iterator[None]:
    """Turn an ``OSError`` writing the output ``out`` (its staging folder beside it refused:
    a folder not writable, a full disk) into ``ExportWriteError`` "cannot write OUT: REASON",
    the one wording of a picture (``--png``, ``-o x.png``) and a scene file (``aion plan
    --export``, ``aion export -o x.ply``), rather than a bare OS error."""
    from aion_cli.formats.export import ExportWriteError

    try:
        yield
    except OSError as exc:
        raise ExportWriteError(
            f"cannot write {out}: {exc.strerror or exc}",
            hint="check free disk space and that the folder is writable",
        ) from exc


class Staged:
    """One output written beside its target and renamed into place (see the module docstring).

    ``Staged(target)`` creates the hidden staging folder next to ``target`` (whose folder must
    exist: :func:`check_output_folder`); write the output at :attr:`path` (a file or folder
    of the target's name that does not exist yet), then :meth:`commit` it or :meth:`discard`
    it. As a context manager it commits on success and discards on any exception.
    ``merge``: the target is a folder to write *into* (``aion export``): the staged folder's
    files replace the same-named files of an existing target folder, others stay; with
    ``recognise``, only files it accepts as aion's own (or empty ones) are replaced, and one it
    refuses stops the commit before any file moves (:class:`OutputPathError`).
    """

    def __init__(
        self,
        target: str | os.PathLike[str],
        *,
        merge: bool = False,
        recognise: Recogniser | None = None,
    ) -> None:
        self.target = Path(os.path.abspath(target))
        self.merge = merge
        self.recognise = recognise
        parent = self.target.parent
        if merge and self.target.is_dir():  # stage inside the folder written into (-o .)
            parent = self.target
        check_output_folder(parent / self.target.name)  # never made here
        with interrupts_held():
            self.folder = Path(
                tempfile.mkdtemp(
                    dir=parent, prefix=staging_prefix(self.target.name), suffix=".tmp"
                )
            )
        self.path = self.folder / self.target.name
        self.done = False

    def commit(self) -> None:
        """Move the finished output into place (replacing the old one), remove the staging
        folder. On failure the previous target is as it was and the staging folder is gone."""
        if self.done:
            return
        try:
            if not _exists(self.path):
                raise OutputPathError(f"nothing was written for {self.target}")
            _fsync_tree(self.path)
            if self.merge and self.target.is_dir() and self.recognise is not None:
                _check_replaced(self.path, self.target, self.recognise)
            with interrupts_held():  # moved in and recorded as such (renames only), or neither
                self._move_in()
                note_committed(self.target)
        finally:
            self.discard()
        fsync_dir(self.target.parent)

    def _move_in(self) -> None:
        if self.merge and self.target.is_dir():
            _merge_into(self.path, self.target)
        elif self.target.is_dir() and not self.target.is_symlink():
            old = self.folder / ".replaced"
            os.rename(self.target, old)
            try:
                os.rename(self.path, self.target)
            except BaseException:
                os.rename(old, self.target)
                raise
        else:
            os.replace(self.path, self.target)

    def discard(self) -> None:
        """Remove the staging folder and whatever was written in it. Idempotent."""
        self.done = True
        shutil.rmtree(self.folder, ignore_errors=True)

    def __enter__(self) -> Staged:
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.discard()


def _check_replaced(src: Path, dst: Path, recognise: Recogniser) -> None:
    """:class:`OutputPathError` when a file of folder ``src`` would replace a file of
    ``dst`` that is neither empty nor accepted by ``recognise`` (nothing is moved)."""
    for entry in sorted(src.iterdir()):
        dest = dst / entry.name
        if entry.is_dir() and dest.is_dir() and not dest.is_symlink():
            _check_replaced(entry, dest, recognise)
        else:
            check_replaceable([dest], recognise)


def check_replaceable(paths: Iterable[Path], recognise: Recogniser) -> None:
    """:class:`OutputPathError` for the first of ``paths`` that exists and is neither empty
    nor accepted by ``recognise``: what a folder written *into* checks before any work, for
    the names it may write (the commit checks the names it did write again)."""
    for dest in paths:
        if _exists(dest) and not (is_empty_file(dest) or recognise(dest)):
            raise OutputPathError(
                f"{dest} exists and is {_what_it_is(dest)}, not a file aion wrote: refusing "
                "to replace it; nothing was written",
                hint=refusal_hint(None),
            )


def _merge_into(src: Path, dst: Path) -> None:
    """Move every entry of folder ``src`` into folder ``dst``: files replace same-named files,
    folders are merged the same way (one rename per file)."""
    for entry in sorted(src.iterdir()):
        dest = dst / entry.name
        if entry.is_dir() and dest.is_dir() and not dest.is_symlink():
            _merge_into(entry, dest)
        else:
            kind = special_kind(dest)
            if kind is not None:
                raise OutputPathError(f"{dest} is {kind}: aion does not replace it")
            os.replace(entry, dest)
