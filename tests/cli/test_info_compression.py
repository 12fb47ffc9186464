"""``aion info`` shows how a log is compressed (table and JSON ``compression``, per file
``files[].compression``), as ``rosbag info`` and ``mcap info`` do, from the index or summary
(no chunk decompressed). Before, neither the table nor the JSON said it. Checked against
third-party files whose compression is known: rosbag.js's fixtures (``example-bz2.bag``,
``example-lz4.bag``, the uncompressed ``example.bag``), rosbag2's own test bags (metadata.yaml
``compression_format: ""``; the talker's mcap storage with zstd chunks, as its chunk indexes
read by the ``mcap`` library say), MCAP conformance files (their .json lists the chunk
indexes), bags rosbags writes with rosbag2 file or message compression, and aion's own
writers (MCAP: zstd chunks)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.conftest import run, run_json
from tests.shared_data import real

T0 = 1_700_000_000 * 1_000_000_000


def _compression(log: Path) -> tuple[list[str], list[list[str]]]:
    info = run_json("info", log, "--format", "json")
    return info["compression"], [f["compression"] for f in info["files"]]


@pytest.mark.parametrize(
    ("name", "expected"),
    [("example-bz2.bag", "bz2"), ("example-lz4.bag", "lz4"), ("example.bag", "none")],
)
def test_ros1_bag_chunk_compression(name: str, expected: str) -> None:
    log = real("logs", "rosbagjs_fixtures", name)
    assert _compression(log) == ([expected], [[expected]])
    table = run("info", log)
    assert table.exit_code == 0, table.stderr
    assert f"compression: {expected}" in " ".join(table.stdout.split())


def test_ros1_bag_without_chunks_holds_nothing_compressed() -> None:
    """rosbag.js's ``no-messages.bag`` has no chunk record (read with the test's own record
    parser): nothing in it is compressed, as an MCAP file without chunks says (``none``);
    before, JSON said ``[]`` (unknown) and the table ``compression: ?``."""
    from tests.formats.test_real_containers import _bag_records

    log = real("logs", "rosbagjs_fixtures", "no-messages.bag")
    ops = {header["op"][0] for header, _ in _bag_records(log.read_bytes(), 13)}
    assert 0x03 in ops  # the bag header record: the parser reads the file
    assert 0x05 not in ops  # no chunk
    assert _compression(log) == (["none"], [["none"]])
    table = run("info", log)
    assert table.exit_code == 0, table.stderr
    assert "compression: none " in " ".join(table.stdout.split())


def _chunk_compressions(path: Path) -> set[str]:
    """The chunk indexes' compressions as the ``mcap`` library reads them."""
    from mcap.reader import make_reader

    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return {c.compression or "none" for c in summary.chunk_indexes}


def test_rosbag2_test_bags() -> None:
    """rosbag2's sqlite3 test bags are uncompressed (metadata.yaml); its mcap talker bag has
    zstd chunks in its storage file, which the bag's metadata does not say."""
    for name in ("rosbag2_py_sqlite3_talker", "rosbag2_tests_sqlite3_cdr_test",
                 "rosbag2_tests_mcap_cdr_test"):  # fmt: skip
        folder = real("logs", "rosbag2_tests", name)
        assert 'compression_format: ""' in (folder / "metadata.yaml").read_text()
        assert _compression(folder)[0] == ["none"], name
    reindexed = real("logs", "rosbag2_tests", "rosbag2_py_sqlite3_reindex_test_bags_multiple_files")
    assert _compression(reindexed)[0] == ["none"]  # no metadata.yaml: plain CDR payloads
    talker = real("logs", "rosbag2_tests", "rosbag2_py_mcap_talker")
    (storage,) = sorted(talker.glob("*.mcap"))
    assert _chunk_compressions(storage) == {"zstd"}
    assert _compression(talker) == (["zstd"], [["zstd"]])


@pytest.mark.parametrize(
    "name",
    ["TenMessages/TenMessages-ch-chx-mx-pad-rch-st.mcap", "TenMessages/TenMessages.mcap",
     "OneMessage/OneMessage-ch-chx-mx-pad-rch-rsh-st-sum.mcap", "NoData/NoData.mcap"],
)  # fmt: skip
def test_mcap_conformance_files(name: str) -> None:
    """The compression of every ChunkIndex record the file's .json lists (empty: none); a
    file without chunks holds nothing compressed."""
    log = real("logs", "mcap_conformance", *name.split("/"))
    records = json.loads(log.with_suffix(".json").read_text())["records"]
    listed = {
        dict(r["fields"])["compression"] or "none" for r in records if r["type"] == "ChunkIndex"
    }
    assert _compression(log)[0] == sorted(listed or {"none"})


def test_own_writers(tmp_path: Path) -> None:
    """aion's MCAP writer compresses its chunks with zstd (the mcap library reads the same
    from the chunk indexes); its bag and rosbag2 writers compress nothing."""
    from aion_cli.formats.writers import LogWriter

    expected = {"mcap": "zstd", "mcap-ros1": "zstd", "bag": "none", "rosbag2-sqlite3": "none",
                "rosbag2-mcap": "none"}  # fmt: skip
    for container, packed in expected.items():
        path = tmp_path / {"bag": "log.bag", "mcap": "log.mcap", "mcap-ros1": "log1.mcap"}.get(
            container, container
        )
        with LogWriter(path, container) as w:
            for k in range(5):
                w.write("/chatter", "std_msgs/msg/String", {"data": f"m{k}"}, T0 + k)
        if container.startswith("mcap"):
            assert _chunk_compressions(path) == {packed}
        assert _compression(path)[0] == [packed], container


@pytest.mark.parametrize("storage", ["SQLITE3", "MCAP"])
@pytest.mark.parametrize("mode", ["FILE", "MESSAGE"])
def test_rosbag2_compression_modes(storage: str, mode: str, tmp_path: Path) -> None:
    """A rosbag2 bag rosbags writes with ``set_compression(mode, ZSTD)`` says so in its
    metadata.yaml; info shows ``zstd (file)`` / ``zstd (message)``."""
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    string = store.types["std_msgs/msg/String"]
    folder = tmp_path / "bag"
    writer = Writer(folder, version=8, storage_plugin=StoragePlugin[storage])
    writer.set_compression(CompressionMode[mode], CompressionFormat.ZSTD)
    with writer:
        conn = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        for k in range(5):
            writer.write(
                conn, T0 + k, store.serialize_cdr(string(data=f"m{k}"), string.__msgtype__)
            )
    meta = (folder / "metadata.yaml").read_text()
    assert "compression_format: zstd" in meta
    assert f"compression_mode: {mode.lower()}" in meta
    assert _compression(folder)[0] == [f"zstd ({mode.lower()})"]
    if (storage, mode) == ("SQLITE3", "MESSAGE"):  # without metadata.yaml: the payloads say it
        (folder / "metadata.yaml").unlink()
        assert _compression(folder)[0] == ["zstd (message)"]
