"""A rosbag2 folder whose mcap storage file was cut short (a copy that did not finish):
rosbags refuses the folder, so aion indexes the storage file itself and reads what it holds.
Its warning said metadata.yaml was not used but not how much of the bag that is; it now says
how many of the messages metadata.yaml counts were read (as for a cut sqlite3 file). Known
answers: the mcap library's own linear read of the cut file (the messages before the cut)
and the count of the whole file."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import NonSeekingReader

from tests.cli.conftest import run, run_json
from tests.shared_data import real


def _messages(path: Path) -> int:
    """Messages the mcap library reads from the start of ``path`` before it fails."""
    n = 0
    with path.open("rb") as f:
        try:
            for _ in NonSeekingReader(f).iter_messages(log_time_order=False):
                n += 1
        except Exception:  # the cut: the library's own error
            pass
    return n


def test_a_cut_mcap_storage_file_says_how_much_of_the_bag_was_read(tmp_path: Path) -> None:
    tracks = real("thor", "thor1-exp-1-run-2.csv")
    bag = tmp_path / "bag"
    converted = run("convert", tracks, "--layout", "thor", "-o", bag, "--container",
                    "rosbag2-mcap", "-q")  # fmt: skip
    assert converted.exit_code == 0, converted.stderr
    (storage,) = bag.glob("*.mcap")
    whole = _messages(storage)
    data = storage.read_bytes()
    storage.write_bytes(data[: len(data) * 7 // 10])
    read = _messages(storage)
    assert 0 < read < whole

    info = run_json("info", bag, "--format", "json")
    assert info["messages"] == read
    (said,) = [w for w in info["warnings"] if "metadata.yaml not used" in w]
    assert said.endswith(f"indexed in memory from its 1 storage file: {read:,} of the "
                         f"{whole:,} messages metadata.yaml counts")  # fmt: skip
