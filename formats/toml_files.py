"""The text of a TOML file the user names (``--config``, ``--detections-mapping``).

One reader for both, so a file that is no text at all (a log or a map given by mistake, a
file in another encoding) is refused as a :class:`~aion_cli.errors.ConfigError` (exit 2,
with the caller's hint) instead of failing inside the decoder, and a huge file is refused
before it is read whole: a TOML file of parameters is a few kilobytes.
"""

from __future__ import annotations

from pathlib import Path

from aion_cli.errors import ConfigError

MAX_TOML_BYTES = 1 << 20
"""The largest file read as TOML (1 MiB; ``aion build --print-config`` writes about 1 KiB)."""


def read_toml_text(path: Path, what: str, hint: str | None = None) -> str:
    """The UTF-8 text of ``path``, ``what`` it is (``"config file"``): :class:`ConfigError`
    with ``hint`` when it cannot be read, is larger than :data:`MAX_TOML_BYTES` or is not
    UTF-8 text. A FIFO or a device is refused before it is opened (opening a FIFO without a
    writer blocks for ever: ``--config`` of a named pipe hung the build)."""
    from aion_cli.formats.raw import check_regular_input

    hint_special = "pass the TOML file itself (a FIFO or device gives no file to read)"
    check_regular_input(path, what, ConfigError, hint_special)
    try:
        with path.open("rb") as fh:
            data = fh.read(MAX_TOML_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"cannot read {what} {path}: {exc.strerror}", hint=hint) from exc
    if len(data) > MAX_TOML_BYTES:
        raise ConfigError(
            f"{what} {path} is larger than {MAX_TOML_BYTES >> 20} MiB: not a TOML file of "
            "settings (a log or a map?)",
            hint=hint,
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{what} {path} is not TOML text: byte {exc.start} is not UTF-8 (a log or a map?)",
            hint=hint,
        ) from exc
