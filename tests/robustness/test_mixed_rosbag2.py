"""rosbag2 folders whose storage files are compressed differently, read back through the
stream, the index times of a build's first pass, ``aion info`` and ``aion build``.

rosbag2 compresses whole storage files (``compression_mode: file``) after each split and the
last one when the recording closes: a recording killed before that leaves a ``.db3.zstd`` (or
``.mcap.zstd``) beside a plain ``.db3``, with or without a metadata.yaml saying ``file``. Bags
recorded with ``compression_mode: message`` compress each payload. rosbag2 keeps one storage
format per bag (metadata.yaml has one ``storage_identifier``): sqlite3 and mcap files in one
folder are refused with one error line.

The messages are 40 people detections a LogWriter wrote into one rosbag2 bag (``whole``); the
folders here hold the same messages in two storage files of 20, so what must come back is
known: those payloads in log-time order, and the map of ``whole``.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest

from aion_cli.errors import LogFormatError
from aion_cli.formats.logs import open_logs
from tests.cli.conftest import run_json
from tests.robustness.conftest import (
    TRACKED,
    assert_same_arrays,
    build_json,
    fails,
    map_arrays,
    run,
    walk,
    write_log,
)

EXT = {"sqlite3": ".db3", "mcap": ".mcap"}


def payloads(folder: Path) -> list[tuple[int, bytes]]:
    with open_logs([folder]) as logs:
        return [(m.log_time_ns, bytes(m.data)) for m in logs.messages()]


@pytest.fixture(scope="module", params=["sqlite3", "mcap"])
def bags(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Any:
    """(storage, the whole bag, its first 20 s and its last 20 s as bags of their own)."""
    storage = request.param
    folder = tmp_path_factory.mktemp(storage)
    container = f"rosbag2-{storage}"
    whole = write_log(folder / "whole", walk(40), container)
    first = write_log(folder / "first", walk(20), container)
    last = write_log(folder / "last", walk(20, start_s=20), container)
    return storage, whole, first, last


def split_bag(bags: Any, folder: Path, packed: tuple[bool, bool], metadata: bool) -> Path:
    """A bag of two storage files (``split_0``, ``split_1``: the first and the last 20 s),
    each zstd-compressed whole or not (``packed``); with ``metadata``, a metadata.yaml
    listing them that says ``compression_mode: file`` (what rosbag2 wrote before it was
    killed) whenever one is compressed."""
    import zstandard
    from ruamel.yaml import YAML

    storage, _, first, last = bags
    ext = EXT[storage]
    folder.mkdir()
    names = []
    for k, (part, zstd) in enumerate(zip((first, last), packed, strict=True)):
        data = next(part.glob(f"*{ext}")).read_bytes()
        name = f"split_{k}{ext}"
        if zstd:
            data, name = zstandard.ZstdCompressor().compress(data), name + ".zstd"
        (folder / name).write_bytes(data)
        names.append(name)
    if metadata:
        yaml = YAML(typ="safe")
        meta = yaml.load((first / "metadata.yaml").read_text())
        info = meta["rosbag2_bagfile_information"]
        info["relative_file_paths"] = names
        info["compression_format"] = "zstd" if any(packed) else ""
        info["compression_mode"] = "file" if any(packed) else ""
        info["message_count"] = 40
        info["topics_with_message_count"][0]["message_count"] = 40
        info["duration"]["nanoseconds"] = 39 * 10**9
        second = dict(info["files"][0], path=names[1])
        second["starting_time"] = {
            "nanoseconds_since_epoch": info["starting_time"]["nanoseconds_since_epoch"] + 20 * 10**9
        }
        info["files"] = [dict(info["files"][0], path=names[0]), second]
        with (folder / "metadata.yaml").open("w") as f:
            yaml.dump(meta, f)
    return folder


@pytest.mark.parametrize(
    ("packed", "metadata", "compression", "warned"),
    [
        ((True, False), True, ["zstd (file)", "none"], "split_1{ext} is not zstd-compressed"),
        ((True, False), False, ["zstd (file)", "none"], "no metadata.yaml; indexed in memory"),
        ((False, True), False, ["none", "zstd (file)"], "no metadata.yaml; indexed in memory"),
        ((True, True), True, ["zstd (file)"], None),
        ((True, True), False, ["zstd (file)"], "no metadata.yaml; indexed in memory"),
    ],
    ids=[
        "last-plain-said-file",
        "last-plain-no-metadata",
        "first-plain-no-metadata",
        "both-compressed",
        "both-compressed-no-metadata",
    ],
)
def test_storage_files_compressed_and_not_in_one_bag(
    packed: tuple[bool, bool],
    metadata: bool,
    compression: list[str],
    warned: str | None,
    bags: Any,
    tmp_path: Path,
) -> None:
    """Every message of both files, in time order, from the stream and the index; info names
    both compressions, in file order (it said ``none`` for sqlite3 files read without
    metadata.yaml, compressed or not), and a metadata.yaml that says ``file`` over a plain
    file is set aside naming that file (rosbags said only "Unable to decompress Zstandard
    data: Unknown frame descriptor")."""
    storage, whole, *_ = bags
    folder = split_bag(bags, tmp_path / "split", packed, metadata)
    want = payloads(whole)
    with open_logs([folder]) as logs:
        assert [(m.log_time_ns, bytes(m.data)) for m in logs.messages()] == want
        index = logs.index_times(["/tracks"], vouch=False)
        assert index is not None
        assert [int(t) for t in index.t] == [t for t, _ in want]
        warnings = logs.warnings
    if warned is None:
        assert warnings == []
    else:
        (line,) = warnings
        assert warned.format(ext=EXT[storage]) in line
    info = run_json("info", folder, "--format", "json")
    assert info["compression"] == compression
    assert (info["messages"], info["start_ns"], info["end_ns"]) == (40, want[0][0], want[-1][0])


def test_a_split_bag_builds_the_map_of_the_whole_recording(bags: Any, tmp_path: Path) -> None:
    """The folder whose last file is plain though metadata.yaml says ``file``: the map of the
    one-file bag holding the same 40 detections."""
    _, whole, *_ = bags
    folder = split_bag(bags, tmp_path / "split", (True, False), True)
    split = build_json(folder, "-o", tmp_path / "split.aion")
    one = build_json(whole, "-o", tmp_path / "whole.aion")
    assert split["detections"] == one["detections"] == {"read": 40, "used": 40, "dropped": {}}
    assert_same_arrays(map_arrays(tmp_path / "split.aion"), map_arrays(tmp_path / "whole.aion"))


def rosbags_bag(folder: Path, storage: str, mode: str, messages: list[tuple[int, bytes]]) -> Path:
    """``messages`` (CDR payloads on /tracks) written by rosbags' own writer with zstd
    compression in ``mode`` (``FILE`` or ``MESSAGE``)."""
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

    from aion_cli.formats import msgdefs

    writer = Writer(folder, version=9, storage_plugin=StoragePlugin[storage.upper()])
    writer.set_compression(CompressionMode[mode], CompressionFormat.ZSTD)
    with writer:
        conn = writer.add_connection("/tracks", TRACKED, typestore=msgdefs.typestore(2))
        for t, data in messages:
            writer.write(conn, t, data)
    return folder


@pytest.mark.parametrize("metadata", [True, False], ids=["metadata", "no-metadata"])
@pytest.mark.parametrize("mode", ["FILE", "MESSAGE"])
def test_rosbags_compression_modes_read_back(
    mode: str, metadata: bool, bags: Any, tmp_path: Path
) -> None:
    """The 40 payloads written again by rosbags' own writer with zstd ``file`` or ``message``
    compression, with its metadata.yaml or without (a recording killed before writing it):
    the same payloads come back, the index gives their times where the payloads are plain
    (message mode: None, the build reads the messages), and the map equals the uncompressed
    bag's. Without metadata.yaml, an mcap storage file's compressed payloads were taken for
    CDR: "none of the 40 messages on /tracks ... could be decoded" (sqlite3's were found by
    their magic bytes)."""
    storage, whole, *_ = bags
    want = payloads(whole)
    folder = rosbags_bag(tmp_path / "packed", storage, mode, want)
    if not metadata:
        (folder / "metadata.yaml").unlink()
    assert payloads(folder) == want
    with open_logs([folder]) as logs:
        index = logs.index_times(["/tracks"], vouch=False)
        if metadata:
            assert logs.warnings == []
        else:
            (line,) = logs.warnings
            assert "packed: no metadata.yaml; indexed in memory from its 1 storage file" in line
    if mode == "FILE":
        assert index is not None
        assert [int(t) for t in index.t] == [t for t, _ in want]
    else:
        assert index is None
    info = run_json("info", folder, "--format", "json")
    assert info["compression"] == [f"zstd ({mode.lower()})"]
    report = build_json(folder, "-o", tmp_path / "packed.aion")
    assert report["detections"] == {"read": 40, "used": 40, "dropped": {}}
    build_json(whole, "-o", tmp_path / "whole.aion")
    assert_same_arrays(map_arrays(tmp_path / "packed.aion"), map_arrays(tmp_path / "whole.aion"))


def test_a_message_compressed_storage_file_given_alone(bags: Any, tmp_path: Path) -> None:
    """The storage file of a bag recorded with message compression, given alone: as a rosbag2
    file (``--log-format rosbag2``; a .db3 is one anyway) its payloads are decompressed; an
    .mcap read as a plain MCAP file is one error line saying its payloads are zstd, not CDR,
    and how to read it (it said the messages had "no little-endian CDR header" and blamed the
    type's definition)."""
    storage, whole, *_ = bags
    folder = rosbags_bag(tmp_path / "packed", storage, "MESSAGE", payloads(whole))
    (alone,) = folder.glob(f"*{EXT[storage]}")
    report = build_json(alone, "--log-format", "rosbag2", "-o", tmp_path / "alone.aion")
    assert report["detections"] == {"read": 40, "used": 40, "dropped": {}}
    if storage == "mcap":
        fails(
            run("build", alone, "-o", tmp_path / "plain.aion"),
            "none of the 40 messages on /tracks",
            "message 0 on '/tracks' is zstd-compressed (starts with 28b52ffd), not CDR",
        )
        assert "hint: a rosbag2 bag recorded with compression_mode: message" in run(
            "build", alone, "-o", tmp_path / "plain.aion"
        ).stderr
        assert not (tmp_path / "plain.aion").exists()


def test_sqlite3_and_mcap_storage_in_one_folder_is_one_error(
    bags: Any, tmp_path: Path
) -> None:
    """rosbag2 keeps one storage format per bag: a folder holding a .db3 and an .mcap (no
    metadata.yaml) is refused, by open_logs and by the CLI with one error line."""
    storage, _, first, _ = bags
    other = "mcap" if storage == "sqlite3" else "sqlite3"
    folder = tmp_path / "both"
    folder.mkdir()
    shutil.copy(next(first.glob(f"*{EXT[storage]}")), folder / f"both_0{EXT[storage]}")
    twin = write_log(tmp_path / "twin", walk(20, start_s=20), f"rosbag2-{other}")
    shutil.copy(next(twin.glob(f"*{EXT[other]}")), folder / f"both_1{EXT[other]}")
    with pytest.raises(LogFormatError, match="holds both sqlite3 and mcap storage files"):
        open_logs([folder])
    for command in ("info", "build"):
        args = [command, folder] + (["-o", tmp_path / "both.aion"] if command == "build" else [])
        fails(run(*args), "holds both sqlite3 and mcap storage files: not the files of one bag")
    assert not (tmp_path / "both.aion").exists()
