"""Warnings about a log compressed whole (``run.mcap.zst``), read through a decompressed
temporary copy: they name the user's file, not the copy, and their byte offsets say they count
in the decompressed data. Expected answers: the warnings of a plain read of the same log."""

from __future__ import annotations

from pathlib import Path

from aion_cli.formats.logs import open_logs
from tests.cli.conftest import run
from tests.formats.test_rosbag2_reindex import _zstd


def test_warnings_on_a_compressed_file_name_it_not_its_temporary_copy(
    tmp_path: Path, temp_root: Path
) -> None:
    """A truncated MCAP compressed with zstd: read as far as it goes, with a warning that
    named the decompressed copy ('cut.mcap: truncated or corrupt MCAP ...'), not the file,
    and gave the copy's byte offsets as if they were the file's ('read stopped at byte 1699
    of 1708', in a file of fewer bytes): they now say they count in the decompressed data."""
    import re

    whole = tmp_path / "whole.mcap"
    _forty_messages(whole, chunk_size=4096)
    plain = tmp_path / "cut.mcap"
    plain.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    (tmp_path / "logs").mkdir()
    packed = _zstd(plain, tmp_path / "logs" / "cut.mcap.zst")
    with open_logs([plain]) as direct, open_logs([packed]) as logs:
        (said,) = direct.warnings
        assert said.startswith("cut.mcap: truncated or corrupt MCAP")
        list(logs.messages())
        list(logs.messages())  # read twice: still one warning
        # the offsets of the plain file, the decompressed data: its size is the second
        at, size = re.search(r"at byte (\d+) of (\d+) ", said).groups()  # type: ignore[union-attr]
        assert int(size) == plain.stat().st_size > packed.stat().st_size
        shown = said.replace(f"at byte {at} of {size} ",
                             f"at byte {at} of the decompressed data's {size} ")
        assert logs.warnings == ["cut.mcap.zst" + shown[len("cut.mcap") :]]
    result = run("info", packed)
    assert result.exit_code == 0, result.stderr
    assert "warning: cut.mcap.zst: truncated or corrupt MCAP" in result.stderr
    assert f"at byte {at} of the decompressed data's {size} " in " ".join(result.stderr.split())
    assert "cut.mcap:" not in result.stderr
    assert list(temp_root.iterdir()) == []


def test_a_corrupt_chunk_of_a_compressed_log_is_placed_in_the_decompressed_data(
    tmp_path: Path, temp_root: Path
) -> None:
    """An MCAP with a damaged chunk, compressed with zstd: the warning gave the chunk's byte
    offset in the decompressed copy as the file's ('corrupt chunk at byte 73 skipped'); it
    now says 'at byte 73 of the decompressed data', the offset a plain read of the same log
    gives."""
    import re

    plain = tmp_path / "bad.mcap"
    _forty_messages(plain, chunk_size=1 << 20)
    data = bytearray(plain.read_bytes())
    for k in range(len(data) // 8, len(data) // 8 + 40):  # inside the one chunk's data
        data[k] ^= 0xFF
    plain.write_bytes(bytes(data))
    (tmp_path / "logs").mkdir()
    packed = _zstd(plain, tmp_path / "logs" / "bad.mcap.zst")
    with open_logs([plain]) as direct, open_logs([packed]) as logs:
        list(direct.messages())
        list(logs.messages())
        (said,) = direct.warnings
        (at,) = re.findall(r"chunk at byte (\d+) skipped", said)
        assert logs.warnings == [
            "bad.mcap.zst" + said[len("bad.mcap"):].replace(
                f"at byte {at} skipped", f"at byte {at} of the decompressed data skipped")
        ]
    assert list(temp_root.iterdir()) == []


def _forty_messages(path: Path, chunk_size: int) -> None:
    """A ROS 2 MCAP of 40 messages of 1 KiB on /e at log times 0..39 ns, in chunks of
    ``chunk_size`` bytes (4096: one chunk per few messages; 1 MiB: one chunk)."""
    from mcap.writer import Writer

    with path.open("wb") as f:
        w = Writer(f, chunk_size=chunk_size)
        w.start(profile="ros2")
        channel = w.register_channel(
            "/e", "cdr", w.register_schema("std_msgs/msg/Empty", "ros2msg", b"")
        )
        for k in range(40):
            w.add_message(channel, k, b"\x00\x01\x00\x00" + k.to_bytes(4, "little") * 256, k)
        w.finish()
